//! Shift-variant ("ray-trace") optics: a PSF per field height and wavelength, rotated to each
//! image block's azimuth and interpolated between field heights, applied blockwise; with a traced
//! lens also its distortion and relative illumination (ISETCam's ray-trace optics,
//! `rtPrecomputePSF` / `rtPrecomputePSFApply`, with the lens model of [`crate::traced`]).
//!
//! Scheme (`blur = { method = "shift-variant", ... }`, [`crate::config::BlurConfig`]):
//! 1. PSFs at `field_heights` heights h_i = i / (n - 1) * (image half-diagonal) along +x, per
//!    wavelength, from a [`Wavefront`] per height: the `[wavefront]` terms plus an interpolated
//!    `field_zernike` table, or the Zernike fit of a traced lens's optical path difference
//!    ([`crate::traced`]); or, from a ray-transfer function (`rtf_file`), the geometric spot of
//!    rays traced through it convolved with its pass ellipse's diffraction ([`crate::rtf_psf`]).
//!    Each PSF is centred on the chief ray.
//! 2. The image is cut into square blocks (the FFT tiles of [`TileConvolver`]); each block gets
//!    the PSF at its centre's field height h and azimuth phi: the two neighbouring field PSFs are
//!    mixed linearly in h, and the mix (stored `rotation_oversampling` times finer) is rotated by
//!    phi, each fine sample binned into the image cell its rotated position falls in (this
//!    conserves energy; the kernel is renormalized to unit sum). A rotationally symmetric model
//!    skips the rotation and mixes the image-sampled kernels directly.
//! 3. Each block is convolved with its kernel by FFT and overlap-added (exact linear convolution
//!    of the block; the blur is piecewise shift-invariant: the PSF jumps at block seams). rayon
//!    over wavelengths, f32, one kernel spectrum buffer per thread.
//! 4. Traced lens or RTF: distortion as a radial resampling of the blurred (ideal-geometry)
//!    irradiance: the output sample at film height r takes the bilinear value at ideal height
//!    D^-1(r), D the chief-ray mapping (550 nm); then the relative illumination at r (which is
//!    computed on the film and so already holds the area change of distortion) as a gain. Applied
//!    in place, strip by strip for all bands at once (`apply_lens_maps`).
//!
//! Accuracy / speed: the cost over the shift-invariant tiled blur is one kernel FFT per block and
//! wavelength (about a third of a block's convolution) plus the kernel rotation and (lens, RTF)
//! the resampling. Measured at 4032 x 3024 x 31, 2 threads, CPU user time
//! (`examples/time_shift_variant.rs`, loaded machine): shift-invariant 3.4-3.7 s; traced dgauss
//! f/2.8 (K = 99) 9.3-9.5 s = 2.7x (11.5-11.8 s = 3.4x before the in-place, all-band resampling,
//! which took 4.4 s streaming a 155 MB per-sample map once per band, and before the mirror
//! blocks' shared kernel spectra). Accuracy is set
//! by the field-height spacing (PSFs mixed linearly between heights) and the block size (the
//! PSF is constant over a block). Smaller blocks follow the field more closely but the FFT tile
//! overhead (kernel side K against block side B: cost ~ (B + K)^2 / B^2) grows.

use crate::config::{BlurConfig, BlurKind, Padding};
use crate::conv::{KernelSpectrum, OutputWindow, TileConvolver};
use crate::error::{OpticsError, Result};
use crate::optics::Optics;
use crate::rtf_psf::RtfLens;
use crate::traced::{ObjectField, TracedLens};
use crate::wavefront::Wavefront;
use camsim_core::{Quantity, SpectralImage};
use camsim_lens::LensCamera;
use rayon::prelude::*;

/// Where the field PSFs come from.
#[derive(Debug, Clone)]
pub enum FieldSource {
    /// `[wavefront]` terms at every height plus a table of terms per field height (local frame).
    Zernike {
        /// Field heights (m in the sensor plane, or normalized to the half-diagonal).
        heights: Vec<f64>,
        /// Heights are normalized.
        normalized: bool,
        /// Dense OSA coefficients per height, um (empty table: field-independent).
        terms_um: Vec<Vec<f64>>,
    },
    /// A traced lens prescription.
    Lens(Box<TracedLens>),
    /// A ray-transfer function ([`crate::rtf_psf`]).
    Rtf(Box<RtfLens>),
}

/// The shift-variant blur settings and PSF source, checked.
#[derive(Debug, Clone)]
pub struct ShiftVariant {
    /// Field heights with PSFs (>= 2).
    pub field_heights: usize,
    /// Block side, samples (None: the cheapest FFT tile).
    pub block_px: Option<usize>,
    /// Fine samples per image sample for the rotation (odd).
    pub rotation_oversampling: usize,
    /// The PSF source.
    pub source: FieldSource,
}

impl ShiftVariant {
    /// Check a `blur` config; `None` for the shift-invariant method.
    pub fn from_config(
        b: &BlurConfig,
        f_number: f64,
        focal_length_mm: f64,
        shading_is_none: bool,
    ) -> Result<Option<ShiftVariant>> {
        if b.method == BlurKind::ShiftInvariant {
            if b.lens_file.is_some() || b.rtf_file.is_some() || b.field_zernike.is_some() {
                return Err(OpticsError::config(
                    "blur.method",
                    "lens_file, rtf_file and field_zernike need method = \"shift-variant\"",
                ));
            }
            return Ok(None);
        }
        if !(2..=64).contains(&b.field_heights) {
            return Err(OpticsError::config(
                "blur.field_heights",
                format!("{} must be 2..=64", b.field_heights),
            ));
        }
        if let Some(p) = b.block_px {
            if !(8..=4096).contains(&p) {
                return Err(OpticsError::config(
                    "blur.block_px",
                    format!("{p} must be 8..=4096"),
                ));
            }
        }
        let s = b.rotation_oversampling;
        if !(1..=9).contains(&s) || s.is_multiple_of(2) {
            return Err(OpticsError::config(
                "blur.rotation_oversampling",
                format!("{s} must be odd, 1..=9"),
            ));
        }
        if [
            b.lens_file.is_some(),
            b.rtf_file.is_some(),
            b.field_zernike.is_some(),
        ]
        .iter()
        .filter(|v| **v)
        .count()
            > 1
        {
            return Err(OpticsError::config(
                "blur",
                "give one of lens_file, rtf_file or field_zernike",
            ));
        }
        if let Some(path) = &b.rtf_file {
            if !shading_is_none {
                return Err(OpticsError::config(
                    "shading",
                    "with blur.rtf_file the ray-transfer function's relative illumination is applied; set shading = \"none\"",
                ));
            }
            let source = FieldSource::Rtf(Box::new(RtfLens::from_file(
                path,
                f_number,
                focal_length_mm,
            )?));
            return Ok(Some(ShiftVariant {
                field_heights: b.field_heights,
                block_px: b.block_px,
                rotation_oversampling: s,
                source,
            }));
        }
        let source = match (&b.lens_file, &b.field_zernike) {
            (Some(_), Some(_)) => {
                return Err(OpticsError::config(
                    "blur",
                    "give one of lens_file, rtf_file or field_zernike",
                ))
            }
            (Some(path), None) => {
                if !shading_is_none {
                    return Err(OpticsError::config(
                        "shading",
                        "with blur.lens_file the lens's traced relative illumination is applied; set shading = \"none\"",
                    ));
                }
                FieldSource::Lens(Box::new(TracedLens::from_file(
                    path,
                    f_number,
                    focal_length_mm,
                )?))
            }
            (None, Some(t)) => {
                let (heights, normalized, key) =
                    match (&t.field_height_mm, &t.field_height_normalized) {
                        (Some(h), None) => (
                            h.iter().map(|v| v * 1e-3).collect::<Vec<_>>(),
                            false,
                            "blur.field_zernike.field_height_mm",
                        ),
                        (None, Some(h)) => (
                            h.clone(),
                            true,
                            "blur.field_zernike.field_height_normalized",
                        ),
                        _ => {
                            return Err(OpticsError::config(
                                "blur.field_zernike",
                                "give exactly one of field_height_mm or field_height_normalized",
                            ))
                        }
                    };
                if heights.is_empty()
                    || heights.iter().any(|v| !(v.is_finite() && *v >= 0.0))
                    || heights.windows(2).any(|p| p[1] <= p[0])
                {
                    return Err(OpticsError::config(
                        key,
                        "field heights must be finite, >= 0 and strictly increasing",
                    ));
                }
                if t.zernike_um.len() != heights.len() {
                    return Err(OpticsError::config(
                        "blur.field_zernike.zernike_um",
                        format!(
                            "{} lists of terms for {} field heights",
                            t.zernike_um.len(),
                            heights.len()
                        ),
                    ));
                }
                for (i, l) in t.zernike_um.iter().enumerate() {
                    if let Some((j, c)) = l.iter().enumerate().find(|(_, c)| !c.is_finite()) {
                        return Err(OpticsError::config(
                            format!("blur.field_zernike.zernike_um[{i}][{j}]"),
                            format!("{c} is not a finite number"),
                        ));
                    }
                    if l.len() > 231 {
                        return Err(OpticsError::config(
                            format!("blur.field_zernike.zernike_um[{i}]"),
                            "at most 231 terms (radial order 20)",
                        ));
                    }
                }
                FieldSource::Zernike {
                    heights,
                    normalized,
                    terms_um: t.zernike_um.clone(),
                }
            }
            (None, None) => FieldSource::Zernike {
                heights: vec![0.0],
                normalized: false,
                terms_um: vec![Vec::new()],
            },
        };
        Ok(Some(ShiftVariant {
            field_heights: b.field_heights,
            block_px: b.block_px,
            rotation_oversampling: s,
            source,
        }))
    }
}

fn interp(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    if xs.len() == 1 || x <= xs[0] {
        return ys[0];
    }
    let n = xs.len();
    if x >= xs[n - 1] {
        return ys[n - 1];
    }
    let i = xs.partition_point(|v| *v < x);
    let t = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
    ys[i - 1] * (1.0 - t) + ys[i] * t
}

/// Linear interpolation that extends the end segments (for the distortion mapping past the
/// traced range).
fn interp_extend(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let n = xs.len();
    let i = xs.partition_point(|v| *v < x).clamp(1, n - 1);
    let t = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
    ys[i - 1] * (1.0 - t) + ys[i] * t
}

/// Distortion and relative illumination of a traced lens on the film.
#[derive(Debug, Clone)]
pub struct LensMaps {
    /// Ideal (rectilinear, thin-lens) image heights, m.
    pub ideal_m: Vec<f64>,
    /// The 550 nm chief ray's film height for each, m.
    pub real_m: Vec<f64>,
    /// Film heights of the relative illumination table, m.
    pub ri_height_m: Vec<f64>,
    /// Relative illumination (1 on the axis).
    pub ri: Vec<f64>,
}

/// What the shift-variant stage needs of the scene geometry.
struct Geometry {
    /// Object distance, m (infinite allowed).
    d_obj_m: f64,
    /// Thin-lens image distance, m.
    v_s_m: f64,
}

impl Geometry {
    fn field(&self, ideal_height_m: f64) -> ObjectField {
        if self.d_obj_m.is_finite() {
            ObjectField::Finite {
                height_mm: ideal_height_m * self.d_obj_m / self.v_s_m * 1e3,
                distance_mm: self.d_obj_m * 1e3,
            }
        } else {
            ObjectField::Infinity {
                tan_theta: ideal_height_m / self.v_s_m,
            }
        }
    }
}

/// The wavefront of field height `i` and band `b` (one entry: the same for every band).
fn pick(wfs: &[Vec<Wavefront>], i: usize, b: usize) -> &Wavefront {
    if wfs[i].len() == 1 {
        &wfs[i][0]
    } else {
        &wfs[i][b]
    }
}

/// Pixel-centre offset from the optical axis (the image centre), samples.
fn centre_offset(i: usize, n: usize) -> f64 {
    i as f64 + 0.5 - n as f64 / 2.0
}

impl ShiftVariant {
    /// The wavefront at each field height (outer) and band (inner; one entry when the model does
    /// not depend on wavelength), and the lens maps for a traced lens.
    fn field_wavefronts(
        &self,
        base: &Wavefront,
        heights_m: &[f64],
        half_diag_m: f64,
        wavelengths_nm: &[f64],
        geo: &Geometry,
    ) -> Result<(Vec<Vec<Wavefront>>, Option<LensCamera>)> {
        match &self.source {
            FieldSource::Zernike {
                heights,
                normalized,
                terms_um,
            } => {
                let field_independent = terms_um.iter().all(|t| t.iter().all(|c| *c == 0.0));
                let n_terms = terms_um
                    .iter()
                    .map(|t| t.len())
                    .max()
                    .unwrap_or(0)
                    .max(base.zernike_um().len());
                let table_h: Vec<f64> = heights
                    .iter()
                    .map(|h| if *normalized { h * half_diag_m } else { *h })
                    .collect();
                let wfs = heights_m
                    .iter()
                    .map(|h| {
                        if field_independent {
                            return Ok(vec![base.clone()]);
                        }
                        let mut c = base.zernike_um().to_vec();
                        c.resize(n_terms, 0.0);
                        for (j, cj) in c.iter_mut().enumerate() {
                            let col: Vec<f64> = terms_um
                                .iter()
                                .map(|t| t.get(j).copied().unwrap_or(0.0))
                                .collect();
                            *cj += interp(&table_h, &col, *h);
                        }
                        Ok(vec![base
                            .clone()
                            .with_zernike(c, base.measurement_pupil_m())?])
                    })
                    .collect::<Result<Vec<_>>>()?;
                Ok((wfs, None))
            }
            FieldSource::Lens(lens) => {
                // Film large enough for a padded output's corner with 50 % distortion margin.
                let cam = lens.camera(geo.d_obj_m * 1e3, 2.0 * 1.5 * 1.25 * half_diag_m * 1e3)?;
                let mut fits: Vec<Result<Vec<Vec<f64>>>> = heights_m
                    .par_iter()
                    .map(|h| {
                        lens.wavefront_zernike_um(&cam, geo.field(*h), wavelengths_nm, [0.0, 0.0])
                    })
                    .collect();
                // Heights where the lens vignettes most of the pupil (its relative illumination is
                // then near 0) reuse the last height whose fit holds.
                for i in 1..fits.len() {
                    if fits[i].is_err() && fits[i - 1].is_ok() {
                        fits[i] = Ok(fits[i - 1].as_ref().map(|v| v.clone()).unwrap_or_default());
                    }
                }
                let fits = fits.into_iter().collect::<Result<Vec<_>>>()?;
                let pupil = base.lens_pupil_diameter_m();
                let wfs = fits
                    .into_iter()
                    .map(|per_band| {
                        per_band
                            .into_iter()
                            .map(|c| base.clone().with_zernike(c, pupil))
                            .collect::<Result<Vec<_>>>()
                    })
                    .collect::<Result<Vec<_>>>()?;
                Ok((wfs, Some(cam)))
            }
            FieldSource::Rtf(_) => {
                Ok((heights_m.iter().map(|_| vec![base.clone()]).collect(), None))
            }
        }
    }

    /// Distortion and relative illumination of the traced lens out to film height
    /// `out_half_diag_m` (the padded output's corner).
    fn lens_maps(
        &self,
        cam: &LensCamera,
        geo: &Geometry,
        out_half_diag_m: f64,
    ) -> Result<LensMaps> {
        let FieldSource::Lens(lens) = &self.source else {
            return Err(OpticsError::Input("lens maps without a lens".into()));
        };
        // Distortion: chief rays out past the padded output's corner.
        let n_table = 48;
        let ideal_m: Vec<f64> = (0..=n_table)
            .map(|i| 1.1 * out_half_diag_m * i as f64 / n_table as f64)
            .collect();
        let chief: Vec<Result<f64>> = ideal_m
            .par_iter()
            .map(|h| {
                if *h == 0.0 {
                    Ok(0.0)
                } else {
                    lens.chief_image_point_mm(cam, geo.field(*h))
                        .map(|p| p[0] * 1e-3)
                }
            })
            .collect();
        // Past the lens's field (chief rays blocked) the mapping is extended linearly from the
        // last traced heights (no light arrives there: the relative illumination is 0).
        let n_ok = chief.iter().take_while(|r| r.is_ok()).count();
        if n_ok < 3 {
            return Err(chief
                .into_iter()
                .find_map(|r| r.err())
                .unwrap_or_else(|| OpticsError::config("blur.lens_file", "no chief ray passes")));
        }
        let m = n_ok - 1;
        let ideal_m: Vec<f64> = ideal_m[..n_ok].to_vec();
        let real_m: Vec<f64> = chief
            .into_iter()
            .take(n_ok)
            .map(|r| r.unwrap_or(0.0))
            .collect();
        if real_m
            .windows(2)
            .any(|p| p[1].partial_cmp(&p[0]) != Some(std::cmp::Ordering::Greater))
        {
            return Err(OpticsError::config(
                "blur.lens_file",
                "the lens's chief-ray image height does not grow with field height over the image (distortion folds)",
            ));
        }
        if real_m[m] > cam.max_film_radius_mm * 1e-3 {
            return Err(OpticsError::config(
                "blur.lens_file",
                "the lens's distortion exceeds 50 % at the image corner",
            ));
        }
        // The table reaches the output's corner on the film (where no chief ray passes the RI
        // integral finds no light: 0).
        let r_max = real_m[m]
            .max(1.05 * out_half_diag_m)
            .min(cam.max_film_radius_mm * 1e-3);
        let ri_height_m: Vec<f64> = (0..=32).map(|i| r_max * i as f64 / 32.0).collect();
        let h_mm: Vec<f64> = ri_height_m.iter().map(|h| h * 1e3).collect();
        let ri = cam.relative_illumination(&h_mm, 64, crate::traced::REFERENCE_WAVELENGTH_NM);
        if ri.iter().any(|v| !v.is_finite()) {
            return Err(OpticsError::config(
                "blur.lens_file",
                "the lens's relative illumination is not finite (no light passes on the axis)",
            ));
        }
        Ok(LensMaps {
            ideal_m,
            real_m,
            ri_height_m,
            ri,
        })
    }

    /// The shift-variant optics stage ([`Optics::compute`] with `blur.method = "shift-variant"`):
    /// `scale` per band is the camera equation's factor, `spacing_m` the sensor-plane sample
    /// spacing, `v_s_m` the image distance, `d_obj_m` the object distance (infinite allowed).
    pub(crate) fn compute(
        &self,
        optics: &Optics,
        radiance: &SpectralImage,
        scale: &[f32],
        spacing_m: f64,
        v_s_m: f64,
        d_obj_m: f64,
    ) -> Result<(SpectralImage, crate::image_map::ImageMap)> {
        let cfg = optics.config();
        if radiance.depth_m.is_some() && cfg.focus_distance_m.is_some() {
            return Err(OpticsError::config(
                "blur.method",
                "\"shift-variant\" does not combine with depth-layered defocus (a depth map with focus_distance_m) yet",
            ));
        }
        let (rows, cols) = (radiance.rows, radiance.cols);
        let grid = radiance.grid;
        let bands = radiance.bands();
        let wavelengths: Vec<f64> = (0..bands).map(|b| grid.wavelength_nm(b)).collect();
        let extra = cfg
            .focus_distance_m
            .map(|fd| optics.defocus_c4_um(fd, d_obj_m))
            .unwrap_or(0.0);
        let base = optics
            .wavefront()
            .clone()
            .with_image_distance(v_s_m)
            .with_extra_defocus_um(extra);
        let half_diag_m = 0.5 * (rows as f64).hypot(cols as f64) * spacing_m;
        let n_h = self.field_heights;
        let heights_m: Vec<f64> = (0..n_h)
            .map(|i| half_diag_m * i as f64 / (n_h - 1) as f64)
            .collect();
        let geo = Geometry { d_obj_m, v_s_m };
        let tail = cfg.psf.tail_energy;
        // Kernel side: as the shift-invariant path, the largest over bands, here also over heights
        // (for the output's padding the model is evaluated first at the unpadded corner).
        let max_kernel = if cfg.psf.max_kernel_size.is_multiple_of(2) {
            cfg.psf.max_kernel_size - 1
        } else {
            cfg.psf.max_kernel_size
        };
        let (wfs, cam) =
            self.field_wavefronts(&base, &heights_m, half_diag_m, &wavelengths, &geo)?;
        let wf_at = |i: usize, b: usize| pick(&wfs, i, b);
        // An RTF's field kernels (fine grid, per height and band) and its film offset.
        let rtf = match &self.source {
            FieldSource::Rtf(l) => {
                let focus_mm = cfg.focus_distance_m.unwrap_or(d_obj_m) * 1e3;
                let dz = l.focus_offset_mm(focus_mm)?;
                let kern = l.field_kernels(
                    &heights_m,
                    &wavelengths,
                    v_s_m,
                    d_obj_m,
                    dz,
                    spacing_m,
                    self.rotation_oversampling,
                    max_kernel,
                    tail,
                )?;
                Some((l, dz, kern))
            }
            _ => None,
        };
        let k = match &rtf {
            Some((_, _, kern)) => kern.k,
            None => (0..n_h * bands)
                .into_par_iter()
                .map(|ib| {
                    wf_at(ib / bands, ib % bands).kernel_size(
                        wavelengths[ib % bands],
                        spacing_m,
                        tail,
                    )
                })
                .max()
                .unwrap_or(1)
                .min(max_kernel),
        };
        let h = k / 2;
        let (pad_r, pad_c) = match cfg.padding {
            Padding::Psf => (h, h),
            Padding::Isetcam => (
                ((rows as f64) / 8.0).round() as usize,
                ((cols as f64) / 8.0).round() as usize,
            ),
            Padding::None => (0, 0),
        };
        let (out_rows, out_cols) = (rows + 2 * pad_r, cols + 2 * pad_c);
        let mut out =
            SpectralImage::zeros(out_rows, out_cols, grid, spacing_m, Quantity::Irradiance)?;
        let out_half_diag_m = 0.5 * (out_rows as f64).hypot(out_cols as f64) * spacing_m;
        let maps = match (&cam, &rtf) {
            (Some(cam), _) => Some(self.lens_maps(cam, &geo, out_half_diag_m)?),
            (None, Some((l, dz, _))) => {
                Some(l.maps(v_s_m * 1e3, d_obj_m * 1e3, *dz, out_half_diag_m)?)
            }
            (None, None) => None,
        };
        let shade = if maps.is_some() {
            None
        } else {
            optics.shading_map(rows, cols, spacing_m, v_s_m)
        };
        let symmetric =
            rtf.is_none() && wfs.iter().flatten().all(|w| w.is_rotationally_symmetric());
        let conv = match self.block_px {
            Some(b) => TileConvolver::with_tile(k, crate::wavefront::fast_fft_len(b + k - 1)),
            None => {
                // Each block also pays its own kernel spectrum and (rotated models) the kernel
                // rotation, which the shift-invariant tile choice does not count (for K = 99 it
                // picks F = 1024): take the power of two >= 4 K when smaller, so blocks are ~3 K
                // wide. Measured (2 cores under load 10, traced dgauss at f/2.8, K = 99, 4032 x
                // 3024 x 31, CPU user time; +-5 % run to run): F = 1024 15.0 s, F = 512 12.6-12.9
                // s, F = 768 12.5 s. For K = 43 (the Zernike example) both give F = 256.
                let inv = TileConvolver::new(k);
                let f = (4 * k).next_power_of_two();
                if f < inv.f {
                    TileConvolver::with_tile(k, f)
                } else {
                    inv
                }
            }
        };
        let t = conv.t;
        // A model whose field PSFs are mirror-symmetric about the meridian (no odd-in-tangential
        // Zernike terms: m < 0) gives mirror-image kernels at mirror-image blocks; with the blocks
        // laid out symmetrically about the axis, one kernel spectrum serves up to four blocks
        // (`flip_spectrum`). The RTF's spots are traced, not symmetrized: each block its own.
        let mirrored = rtf.is_none() && wfs.iter().flatten().all(meridional);
        let (spans_r, spans_c) = if mirrored {
            (symmetric_spans(rows, t), symmetric_spans(cols, t))
        } else {
            (plain_spans(rows, t), plain_spans(cols, t))
        };
        // Each block's field height (as a fractional index into heights_m) and azimuth.
        let dh = half_diag_m / (n_h - 1) as f64;
        let block = |a: usize, bc: usize| -> Block {
            let ((r0, nr, _), (c0, nc, _)) = (spans_r[a], spans_c[bc]);
            let y = (r0 as f64 + nr as f64 / 2.0 - rows as f64 / 2.0) * spacing_m;
            let x = (c0 as f64 + nc as f64 / 2.0 - cols as f64 / 2.0) * spacing_m;
            let u = (x.hypot(y) / dh).min((n_h - 1) as f64);
            let i = (u.floor() as usize).min(n_h - 2);
            let phi = y.atan2(x);
            Block {
                r0,
                c0,
                nr,
                nc,
                i,
                tt: (u - i as f64) as f32,
                cphi: phi.cos(),
                sphi: phi.sin(),
            }
        };
        // Groups: a block whose kernel is built, and the mirror blocks (flip x, flip y) that reuse
        // its spectrum.
        let mut groups: Vec<BlockGroup> = Vec::new();
        for (a, &(_, _, ma)) in spans_r.iter().enumerate() {
            for (bc, &(_, _, mb)) in spans_c.iter().enumerate() {
                if !mirrored {
                    groups.push((block(a, bc), Vec::new()));
                    continue;
                }
                // The representative lies at or past the axis in both directions.
                if ma < a || mb < bc {
                    continue;
                }
                let mut m = Vec::new();
                if mb != bc {
                    m.push((block(a, mb), true, false));
                }
                if ma != a {
                    m.push((block(ma, bc), false, true));
                }
                if ma != a && mb != bc {
                    m.push((block(ma, mb), true, true));
                }
                groups.push((block(a, bc), m));
            }
        }
        // Phase factors of the flips: exp(-2 pi i u (K - 1) / F) for u = 0..F.
        let phase: Vec<rustfft::num_complex::Complex32> = (0..conv.f)
            .map(|u| {
                let a = -2.0 * std::f64::consts::PI * (u * (k - 1)) as f64 / conv.f as f64;
                rustfft::num_complex::Complex32::new(a.cos() as f32, a.sin() as f32)
            })
            .collect();
        let s = if symmetric {
            1
        } else {
            self.rotation_oversampling
        };
        let ks = k * s;
        let oversampling = cfg.psf.oversampling;
        let win = OutputWindow {
            rows: out_rows,
            cols: out_cols,
            off_r: pad_r as isize,
            off_c: pad_c as isize,
        };
        let plane = rows * cols;
        out.data
            .par_chunks_mut(out_rows * out_cols)
            .enumerate()
            .try_for_each(|(b, out_band)| -> Result<()> {
                // `out` is SpectralImage::zeros: no second zeroing pass (that pass only faulted the
                // pages in ahead of the tiles).
                let wl = wavelengths[b];
                // Field PSFs of this band: image-sampled kernels (symmetric) or s-times finer.
                let psfs: Vec<Vec<f32>> = (0..n_h)
                    .map(|i| {
                        if let Some((_, _, kern)) = &rtf {
                            return Ok(kern.kernels[i][b].clone());
                        }
                        let w = wf_at(i, b);
                        let p = if s == 1 {
                            w.psf_with(wl, spacing_m, k, oversampling)?
                        } else {
                            w.clone().with_kernel_field(1.3).psf_with(
                                wl,
                                spacing_m / s as f64,
                                ks,
                                1,
                            )?
                        };
                        Ok(p.to_f32())
                    })
                    .collect::<Result<_>>()?;
                let src = &radiance.data[b * plane..(b + 1) * plane];
                let sc = scale[b];
                let mut scratch = conv.scratch();
                let mut spec = KernelSpectrum(Vec::new());
                let mut kernel = vec![0.0f32; k * k];
                let hf = (ks / 2) as f32;
                let hk = (k / 2) as f32;
                let inv_s = 1.0 / s as f32;
                let mut spec2 = KernelSpectrum(Vec::new());
                for (rep, mirrors) in &groups {
                    let Block {
                        i, tt, cphi, sphi, ..
                    } = *rep;
                    let (a, bb) = (&psfs[i], &psfs[i + 1]);
                    if s == 1 {
                        kernel
                            .iter_mut()
                            .zip(a.iter().zip(bb))
                            .for_each(|(kv, (x, y))| *kv = x + tt * (y - x));
                    } else {
                        kernel.iter_mut().for_each(|v| *v = 0.0);
                        let (cp, sp) = (cphi as f32, sphi as f32);
                        let kf = k as f32;
                        for r in 0..ks {
                            let yf = (r as f32 - hf) * inv_s;
                            let (row_a, row_b) =
                                (&a[r * ks..(r + 1) * ks], &bb[r * ks..(r + 1) * ks]);
                            // Rotate the local (radial x, tangential y) offset to azimuth phi. Runs of
                            // fine samples that land in one image cell (about s in a row) are summed
                            // in a register and stored once (no store-to-load chain through the cell).
                            let (bx, by) = (hk + 0.5 - yf * sp, hk + 0.5 + yf * cp);
                            let (mut cell, mut run) = (usize::MAX, 0.0f32);
                            for c in 0..ks {
                                let v = row_a[c] + tt * (row_b[c] - row_a[c]);
                                let xf = (c as f32 - hf) * inv_s;
                                let xr = xf * cp + bx;
                                let yr = xf * sp + by;
                                let idx = if xr >= 0.0 && yr >= 0.0 && xr < kf && yr < kf {
                                    yr as usize * k + xr as usize
                                } else {
                                    usize::MAX
                                };
                                if idx != cell {
                                    if cell != usize::MAX {
                                        kernel[cell] += run;
                                    }
                                    (cell, run) = (idx, 0.0);
                                }
                                run += v;
                            }
                            if cell != usize::MAX {
                                kernel[cell] += run;
                            }
                        }
                    }
                    let sum: f32 = kernel.iter().sum();
                    if sum.is_nan() || sum <= 0.0 {
                        return Err(OpticsError::Input(format!(
                            "the field PSF at {wl} nm has no energy inside the {k} x {k} kernel"
                        )));
                    }
                    if s > 1 {
                        kernel.iter_mut().for_each(|v| *v /= sum);
                    }
                    conv.kernel_spectrum_in(&kernel, &mut scratch, &mut spec);
                    let shade = shade.as_deref();
                    let mut blur =
                        |bl: &Block, sp: &KernelSpectrum, scratch: &mut crate::conv::Scratch| {
                            let Block { r0, c0, nr, nc, .. } = *bl;
                            conv.tile_sum(
                                r0,
                                c0,
                                nr,
                                nc,
                                &[sp],
                                out_band,
                                win,
                                scratch,
                                |_, r, dst| {
                                    let i0 = (r0 + r) * cols + c0;
                                    let row = &src[i0..i0 + nc];
                                    match shade {
                                        None => {
                                            dst.iter_mut().zip(row).for_each(|(d, v)| *d = v * sc)
                                        }
                                        Some(sh) => dst
                                            .iter_mut()
                                            .zip(row)
                                            .zip(&sh[i0..i0 + nc])
                                            .for_each(|((d, v), w)| *d = v * sc * w),
                                    }
                                },
                            );
                        };
                    blur(rep, &spec, &mut scratch);
                    for (bl, fx, fy) in mirrors {
                        flip_spectrum(&spec, &mut spec2, conv.f, &phase, *fx, *fy);
                        blur(bl, &spec2, &mut scratch);
                    }
                }
                out_band.iter_mut().for_each(|v| *v = v.max(0.0));
                Ok(())
            })?;
        if let Some(m) = &maps {
            apply_lens_maps(&mut out, m, spacing_m);
        }
        let map = crate::image_map::ImageMap::new(
            rows,
            cols,
            out_rows,
            out_cols,
            maps.as_ref()
                .map(|m| RadialLut::new(m, out_rows, out_cols, spacing_m)),
        );
        Ok((
            optics.finish(out, radiance, (pad_r, pad_c), spacing_m, v_s_m),
            map,
        ))
    }
}

/// Distortion (radial resampling, bilinear, zero outside) and relative illumination (gain at the
/// film height) on every band of `out`, centred on the optical axis, in place.
///
/// The mapping is the same for every band, so it is evaluated once per output sample and strip of
/// rows and applied to all bands while it is in cache ([`RadialLut`]: distortion and relative
/// illumination are even in the film radius, tabulated in r^2). In place: the strips are done top
/// to bottom; before a strip is overwritten its original rows are saved in a ring that holds the
/// last `D + strip` rows, D the largest row shift of the mapping, so every source row is either
/// still untouched (below the strip) or in the ring. Bands are split into one group per worker
/// (each band's result does not depend on the grouping). No image-sized buffer: fresh pages cost
/// more than the resampling on this class of machine.
fn apply_lens_maps(out: &mut SpectralImage, m: &LensMaps, spacing_m: f64) {
    let (rows, cols) = (out.rows, out.cols);
    let plane = rows * cols;
    let bands = out.bands();
    let lut = RadialLut::new(m, rows, cols, spacing_m);
    const STRIP: usize = 8;
    let d_rows = lut.max_row_shift();
    let ring_rows = d_rows + STRIP + 2;
    let group = bands.div_ceil(rayon::current_num_threads().max(1)).max(1);
    out.data.par_chunks_mut(plane * group).for_each(|grp| {
        let nb = grp.len() / plane;
        let mut rings = vec![0.0f32; nb * ring_rows * cols];
        let mut taps: Vec<Tap> = Vec::with_capacity(STRIP * cols);
        for r0 in (0..rows).step_by(STRIP) {
            let r_end = (r0 + STRIP).min(rows);
            taps.clear();
            for r in r0..r_end {
                for c in 0..cols {
                    taps.push(lut.tap(r, c));
                }
            }
            // Source rows a strip may read: [lo, hi).
            let lo = r0.saturating_sub(d_rows + 1);
            let hi = (r_end + d_rows + 1).min(rows);
            for (band, ring) in grp
                .chunks_mut(plane)
                .zip(rings.chunks_mut(ring_rows * cols))
            {
                for r in r0..r_end {
                    let k = r % ring_rows;
                    ring[k * cols..(k + 1) * cols].copy_from_slice(&band[r * cols..(r + 1) * cols]);
                }
                let (head, rest) = band.split_at_mut(r_end * cols);
                let ring: &[f32] = ring;
                let rest: &[f32] = rest;
                let src_rows: Vec<&[f32]> = (lo..hi)
                    .map(|r| {
                        if r >= r_end {
                            &rest[(r - r_end) * cols..(r - r_end + 1) * cols]
                        } else {
                            let k = r % ring_rows;
                            &ring[k * cols..(k + 1) * cols]
                        }
                    })
                    .collect();
                let row = |r: i32| -> Option<&[f32]> {
                    if r >= lo as i32 && r < hi as i32 {
                        Some(src_rows[(r - lo as i32) as usize])
                    } else {
                        None
                    }
                };
                for (d, t) in head[r0 * cols..].iter_mut().zip(taps.iter()) {
                    let v = if t.inside {
                        let (a, b) = (
                            src_rows[t.row as usize - lo],
                            src_rows[t.row as usize + 1 - lo],
                        );
                        let c = t.col as usize;
                        (a[c] * (1.0 - t.fx) + a[c + 1] * t.fx) * (1.0 - t.fy)
                            + (b[c] * (1.0 - t.fx) + b[c + 1] * t.fx) * t.fy
                    } else {
                        let at = |r: i32, c: i32| match row(r) {
                            Some(x) if c >= 0 && (c as usize) < cols => x[c as usize],
                            _ => 0.0,
                        };
                        (at(t.row, t.col) * (1.0 - t.fx) + at(t.row, t.col + 1) * t.fx)
                            * (1.0 - t.fy)
                            + (at(t.row + 1, t.col) * (1.0 - t.fx)
                                + at(t.row + 1, t.col + 1) * t.fx)
                                * t.fy
                    };
                    *d = (v * t.gain).max(0.0);
                }
            }
        }
    });
}

/// One output sample's bilinear source taps: top-left source row and column, weights, gain;
/// `inside`: all four taps lie in the image.
#[derive(Clone, Copy)]
struct Tap {
    row: i32,
    col: i32,
    fx: f32,
    fy: f32,
    gain: f32,
    inside: bool,
}

/// Ideal / film height ratio and relative illumination against the squared film radius (samples^2).
#[derive(Debug, Clone)]
pub(crate) struct RadialLut {
    rows: usize,
    cols: usize,
    inv_step: f64,
    scale: Vec<f64>,
    gain: Vec<f64>,
}

impl RadialLut {
    /// Entries: over the image's r^2 the table's linear interpolation error is far below the
    /// maps' own (piecewise linear in r on 33-129 points).
    const N: usize = 16384;

    pub(crate) fn new(m: &LensMaps, rows: usize, cols: usize, spacing_m: f64) -> RadialLut {
        let r2_max = ((rows * rows + cols * cols) as f64 / 4.0 + 4.0 * (rows + cols) as f64) * 1.01;
        let step = r2_max / (Self::N - 1) as f64;
        let slope0 = if m.real_m.len() > 1 && m.real_m[1] > 0.0 {
            m.ideal_m[1] / m.real_m[1]
        } else {
            1.0
        };
        let (scale, gain) = (0..Self::N)
            .map(|i| {
                let h_real = (i as f64 * step).sqrt() * spacing_m;
                let f = if h_real > 0.0 {
                    interp_extend(&m.real_m, &m.ideal_m, h_real) / h_real
                } else {
                    slope0
                };
                (f, interp(&m.ri_height_m, &m.ri, h_real))
            })
            .unzip();
        RadialLut {
            rows,
            cols,
            inv_step: 1.0 / step,
            scale,
            gain,
        }
    }

    /// The ideal / film height ratio and the gain at film offset (`x`, `y`) samples from the
    /// axis (the one place the distortion is looked up: the resampling and the labels'
    /// [`crate::image_map::ImageMap`]).
    pub(crate) fn at(&self, x: f64, y: f64) -> (f64, f32) {
        let u = ((x * x + y * y) * self.inv_step).min((Self::N - 2) as f64);
        let i = u as usize;
        let t = u - i as f64;
        let f = self.scale[i] + t * (self.scale[i + 1] - self.scale[i]);
        let gain = (self.gain[i] + t * (self.gain[i + 1] - self.gain[i])) as f32;
        (f, gain)
    }

    /// The taps of output sample (r, c).
    fn tap(&self, r: usize, c: usize) -> Tap {
        let (x, y) = (centre_offset(c, self.cols), centre_offset(r, self.rows));
        let (f, gain) = self.at(x, y);
        let (sx, sy) = (
            x * f + self.cols as f64 / 2.0 - 0.5,
            y * f + self.rows as f64 / 2.0 - 0.5,
        );
        // Far outside (beyond one sample of the image) nothing is read: the clamp keeps i32.
        let (x0, y0) = (
            sx.floor().clamp(-2.0, self.cols as f64 + 1.0),
            sy.floor().clamp(-2.0, self.rows as f64 + 1.0),
        );
        let inside =
            x0 >= 0.0 && y0 >= 0.0 && x0 + 1.0 < self.cols as f64 && y0 + 1.0 < self.rows as f64;
        Tap {
            row: y0 as i32,
            col: x0 as i32,
            fx: (sx - sx.floor()) as f32,
            fy: (sy - sy.floor()) as f32,
            gain,
            inside,
        }
    }

    /// The largest |source row - output row| over the image, rounded up, plus 2.
    fn max_row_shift(&self) -> usize {
        let half = self.rows as f64 / 2.0;
        let step = 1.0 / self.inv_step;
        let d = (0..Self::N)
            .map(|i| {
                let r = (i as f64 * step).sqrt();
                r.min(half + 1.0) * (self.scale[i] - 1.0).abs()
            })
            .fold(0.0, f64::max);
        d.ceil() as usize + 2
    }
}

/// A block whose kernel is built and the mirror blocks (flip in x, flip in y) that reuse its
/// spectrum.
type BlockGroup = (Block, Vec<(Block, bool, bool)>);

/// One block of the shift-variant blur: its rows and columns, field-height index and weight, azimuth.
#[derive(Debug, Clone, Copy)]
struct Block {
    r0: usize,
    c0: usize,
    nr: usize,
    nc: usize,
    i: usize,
    tt: f32,
    cphi: f64,
    sphi: f64,
}

/// Spans (start, length, index of the mirror span) of side `t` from 0.
fn plain_spans(n: usize, t: usize) -> Vec<(usize, usize, usize)> {
    (0..n.div_ceil(t))
        .map(|j| (j * t, t.min(n - j * t), j))
        .collect()
}

/// Spans of side <= `t` laid out symmetrically about n / 2 (mirror of [a, b) is [n - b, n - a)),
/// with the index of each span's mirror: for odd n a centre span of odd length, then spans of `t`
/// outward, cut at the ends.
fn symmetric_spans(n: usize, t: usize) -> Vec<(usize, usize, usize)> {
    let (centre, mut lo) = if n.is_multiple_of(2) {
        (None, n / 2)
    } else {
        let tc = (if t % 2 == 1 { t } else { t - 1 }).min(n);
        let a = (n - tc) / 2;
        (Some((a, tc)), a + tc)
    };
    let mut upper = Vec::new();
    while lo < n {
        let len = t.min(n - lo);
        upper.push((lo, len));
        lo += len;
    }
    let mut v: Vec<(usize, usize)> = upper.iter().rev().map(|(a, l)| (n - a - l, *l)).collect();
    v.extend(centre);
    v.extend(upper);
    let m = v.len();
    v.into_iter()
        .enumerate()
        .map(|(j, (a, l))| (a, l, m - 1 - j))
        .collect()
}

/// Whether a wavefront is mirror-symmetric about its local x axis (the meridian): no Zernike
/// term odd in y (OSA m < 0) above round-off.
fn meridional(w: &Wavefront) -> bool {
    let c = w.zernike_um();
    let big = c.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    c.iter()
        .enumerate()
        .all(|(j, v)| crate::zernike::osa_to_nm(j).1 >= 0 || v.abs() <= 1e-9 * big.max(1e-12))
}

/// The spectrum (layout of [`TileConvolver::kernel_spectrum_in`]: column frequency v major, row
/// frequency u minor, v = 0..F/2) of the kernel mirrored in x (`fx`: k(y, K-1-x)) and/or in y
/// (`fy`: k(K-1-y, x)), from the spectrum S of k: by the DFT shift and reversal theorems and the
/// Hermitian symmetry of a real kernel, S(u, -v) = conj S(-u, v):
/// x: exp(-2 pi i v (K-1) / F) conj S(-u, v); y: exp(-2 pi i u (K-1) / F) S(-u, v);
/// both: exp(-2 pi i (u + v) (K-1) / F) conj S(u, v). `phase[u]` = exp(-2 pi i u (K-1) / F).
fn flip_spectrum(
    src: &KernelSpectrum,
    dst: &mut KernelSpectrum,
    f: usize,
    phase: &[rustfft::num_complex::Complex32],
    fx: bool,
    fy: bool,
) {
    dst.0.resize(src.0.len(), Default::default());
    for (v, (col_s, col_d)) in src
        .0
        .chunks_exact(f)
        .zip(dst.0.chunks_exact_mut(f))
        .enumerate()
    {
        for (u, d) in col_d.iter_mut().enumerate() {
            let neg = (f - u) % f;
            *d = match (fx, fy) {
                (true, false) => phase[v] * col_s[neg].conj(),
                (false, true) => phase[u] * col_s[neg],
                (true, true) => phase[u] * phase[v] * col_s[u].conj(),
                (false, false) => col_s[u],
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The flipped spectra equal the spectra of the flipped kernels (an asymmetric kernel, all
    /// three flips), and the symmetric spans mirror each other and tile the axis.
    #[test]
    fn flipped_spectrum_is_the_spectrum_of_the_flipped_kernel() {
        let (k, f) = (7usize, 32usize);
        let conv = TileConvolver::with_tile(k, f);
        let kern: Vec<f32> = (0..k * k)
            .map(|i| ((i * 37 % 11) as f32 + 0.3 * (i / k) as f32) / 50.0)
            .collect();
        let phase: Vec<rustfft::num_complex::Complex32> = (0..f)
            .map(|u| {
                let a = -2.0 * std::f64::consts::PI * (u * (k - 1)) as f64 / f as f64;
                rustfft::num_complex::Complex32::new(a.cos() as f32, a.sin() as f32)
            })
            .collect();
        let spec = conv.kernel_spectrum(&kern);
        for (fx, fy) in [(true, false), (false, true), (true, true)] {
            let flipped: Vec<f32> = (0..k * k)
                .map(|i| {
                    let (r, c) = (i / k, i % k);
                    let (r, c) = (
                        if fy { k - 1 - r } else { r },
                        if fx { k - 1 - c } else { c },
                    );
                    kern[r * k + c]
                })
                .collect();
            let want = conv.kernel_spectrum(&flipped);
            let mut got = KernelSpectrum(Vec::new());
            flip_spectrum(&spec, &mut got, f, &phase, fx, fy);
            let err = got
                .0
                .iter()
                .zip(&want.0)
                .map(|(a, b)| (a - b).norm())
                .fold(0.0f32, f32::max);
            assert!(err < 1e-6, "flip ({fx}, {fy}): {err}");
        }
        for (n, t) in [(3024usize, 414usize), (301, 60), (7, 4), (5, 9)] {
            let sp = symmetric_spans(n, t);
            assert_eq!(sp.iter().map(|s| s.1).sum::<usize>(), n);
            assert!(sp.windows(2).all(|w| w[0].0 + w[0].1 == w[1].0) && sp[0].0 == 0);
            for (j, &(a, l, m)) in sp.iter().enumerate() {
                assert!(l <= t);
                assert_eq!((sp[m].0, sp[m].1, sp[m].2), (n - a - l, l, j));
            }
        }
    }
}
