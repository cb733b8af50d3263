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

use crate::config::{BlurConfig, BlurKind, OpticsConfig, Padding};
use crate::conv::{KernelSpectrum, OutputWindow, TileConvolver};
use crate::error::{OpticsError, Result};
use crate::image_map::ImageMap;
use crate::lens_maps::{apply_lens_maps, interp, LensMaps, RadialLut};
use crate::measured_psf::MeasuredPsf;
use crate::rtf_psf::{FieldKernels, RtfLens};
use crate::sv_blocks::{
    block_groups, block_kernel, flip_phases, flip_spectrum, meridional, Block, BlockGroup,
};
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
    /// Measured PSFs ([`crate::measured_psf`]).
    Measured(Box<MeasuredPsf>),
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
    /// `blur.ghosts` of a traced lens: its two-bounce ghosts of the brightest sources, added
    /// after the lens maps ([`crate::traced::TracedLens::add_ghosts`]).
    pub ghosts: Option<crate::traced::Ghosts>,
}

/// What the shift-variant stage takes from the optics (`Optics::compute`).
pub(crate) struct SvJob<'a> {
    /// The lens config.
    pub config: &'a OpticsConfig,
    /// The on-axis wavefront at the image distance, with the defocus of the focus setting.
    pub wavefront: Wavefront,
    /// The lens shading gain per input sample (built only when no lens maps apply).
    pub shading: &'a (dyn Fn() -> Option<Vec<f32>> + Sync),
}

/// One image's field model: wavelengths, the PSF source per field height and band, kernel side.
struct FieldModel<'a> {
    wavelengths: Vec<f64>,
    /// Half the image diagonal in the sensor plane, m (the largest field height).
    half_diag_m: f64,
    /// Wavefront per field height (outer) and band (inner; one entry: every band).
    wfs: Vec<Vec<Wavefront>>,
    /// A traced lens's camera.
    cam: Option<LensCamera>,
    /// An RTF: the lens, its film offset (mm) and field kernels.
    rtf: Option<(&'a RtfLens, f64, FieldKernels)>,
    /// Measured PSFs' field kernels.
    measured: Option<FieldKernels>,
    /// Kernel side, samples (odd).
    k: usize,
}

/// What blurring one band needs ([`ShiftVariant::blur_band`]).
struct BandJob<'a> {
    field: &'a FieldModel<'a>,
    groups: &'a [BlockGroup],
    conv: &'a TileConvolver,
    phase: &'a [rustfft::num_complex::Complex32],
    /// Fine samples per image sample of the field PSFs (1: no rotation).
    s: usize,
    oversampling: usize,
    shade: Option<&'a [f32]>,
    win: OutputWindow,
    radiance: &'a SpectralImage,
    scale: &'a [f32],
    spacing_m: f64,
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
            if b.lens_file.is_some()
                || b.rtf_file.is_some()
                || b.field_zernike.is_some()
                || b.measured_psf.is_some()
            {
                return Err(OpticsError::config(
                    "blur.method",
                    "lens_file, rtf_file, field_zernike and measured_psf need method = \"shift-variant\"",
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
            b.measured_psf.is_some(),
        ]
        .iter()
        .filter(|v| **v)
        .count()
            > 1
        {
            return Err(OpticsError::config(
                "blur",
                "give one of lens_file, rtf_file, field_zernike or measured_psf",
            ));
        }
        if let Some(m) = &b.measured_psf {
            if b.ghosts.is_some() {
                return Err(OpticsError::config(
                    "blur.ghosts",
                    "ghosts are traced through a lens prescription: give blur.lens_file (not measured_psf)",
                ));
            }
            return Ok(Some(ShiftVariant {
                field_heights: b.field_heights,
                block_px: b.block_px,
                rotation_oversampling: s,
                source: FieldSource::Measured(Box::new(MeasuredPsf::from_config(m)?)),
                ghosts: None,
            }));
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
            if b.ghosts.is_some() {
                return Err(OpticsError::config(
                    "blur.ghosts",
                    "ghosts are traced through a lens prescription: give blur.lens_file (not rtf_file)",
                ));
            }
            return Ok(Some(ShiftVariant {
                field_heights: b.field_heights,
                block_px: b.block_px,
                rotation_oversampling: s,
                source,
                ghosts: None,
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
        let ghosts = match (&b.ghosts, &source) {
            (None, _) => None,
            (Some(g), FieldSource::Lens(l)) => {
                Some(crate::traced::Ghosts::from_config(g, &l.lens)?)
            }
            (Some(_), _) => {
                return Err(OpticsError::config(
                    "blur.ghosts",
                    "ghosts are traced through a lens prescription: give blur.lens_file",
                ))
            }
        };
        Ok(Some(ShiftVariant {
            field_heights: b.field_heights,
            block_px: b.block_px,
            rotation_oversampling: s,
            source,
            ghosts,
        }))
    }
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
            FieldSource::Rtf(_) | FieldSource::Measured(_) => {
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

    /// The field model of one image: wavelengths, field heights, the wavefront (or RTF kernels)
    /// per height and band, and the kernel side.
    fn field_model(
        &self,
        job: &SvJob<'_>,
        radiance: &SpectralImage,
        spacing_m: f64,
        geo: &Geometry,
    ) -> Result<FieldModel<'_>> {
        let cfg = job.config;
        let (rows, cols) = (radiance.rows, radiance.cols);
        let grid = radiance.grid;
        let bands = radiance.bands();
        let wavelengths: Vec<f64> = (0..bands).map(|b| grid.wavelength_nm(b)).collect();
        let half_diag_m = 0.5 * (rows as f64).hypot(cols as f64) * spacing_m;
        let n_h = self.field_heights;
        let heights_m: Vec<f64> = (0..n_h)
            .map(|i| half_diag_m * i as f64 / (n_h - 1) as f64)
            .collect();
        let tail = cfg.psf.tail_energy;
        // Kernel side: as the shift-invariant path, the largest over bands, here also over heights
        // (for the output's padding the model is evaluated first at the unpadded corner).
        let max_kernel = if cfg.psf.max_kernel_size.is_multiple_of(2) {
            cfg.psf.max_kernel_size - 1
        } else {
            cfg.psf.max_kernel_size
        };
        let (wfs, cam) =
            self.field_wavefronts(&job.wavefront, &heights_m, half_diag_m, &wavelengths, geo)?;
        // An RTF's field kernels (fine grid, per height and band) and its film offset.
        let rtf = match &self.source {
            FieldSource::Rtf(l) => {
                let focus_mm = cfg.focus_distance_m.unwrap_or(geo.d_obj_m) * 1e3;
                let dz = l.focus_offset_mm(focus_mm)?;
                let kern = l.field_kernels(
                    &heights_m,
                    &wavelengths,
                    geo.v_s_m,
                    geo.d_obj_m,
                    dz,
                    spacing_m,
                    self.rotation_oversampling,
                    max_kernel,
                    tail,
                )?;
                Some((&**l, dz, kern))
            }
            _ => None,
        };
        let measured = match &self.source {
            FieldSource::Measured(m) => Some(m.field_kernels(
                &heights_m,
                &wavelengths,
                spacing_m,
                self.rotation_oversampling,
                max_kernel,
            )?),
            _ => None,
        };
        let k = match (&rtf, &measured) {
            (Some((_, _, kern)), _) | (None, Some(kern)) => kern.k,
            (None, None) => (0..n_h * bands)
                .into_par_iter()
                .map(|ib| {
                    pick(&wfs, ib / bands, ib % bands).kernel_size(
                        wavelengths[ib % bands],
                        spacing_m,
                        tail,
                    )
                })
                .max()
                .unwrap_or(1)
                .min(max_kernel),
        };
        Ok(FieldModel {
            wavelengths,
            half_diag_m,
            wfs,
            cam,
            rtf,
            measured,
            k,
        })
    }

    /// The FFT tile convolver for kernel side `k`.
    fn convolver(&self, k: usize) -> TileConvolver {
        match self.block_px {
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
        }
    }

    /// Band `b`'s field PSFs, one per height: the image-sampled kernels (`s` = 1) or `s` times
    /// finer ones for the rotation.
    fn band_psfs(
        &self,
        f: &FieldModel<'_>,
        b: usize,
        spacing_m: f64,
        s: usize,
        oversampling: usize,
    ) -> Result<Vec<Vec<f32>>> {
        let (k, wl) = (f.k, f.wavelengths[b]);
        (0..self.field_heights)
            .map(|i| {
                if let Some(kern) = f.rtf.as_ref().map(|r| &r.2).or(f.measured.as_ref()) {
                    return Ok(kern.kernels[i][b].clone());
                }
                let w = pick(&f.wfs, i, b);
                let p = if s == 1 {
                    w.psf_with(wl, spacing_m, k, oversampling)?
                } else {
                    w.clone()
                        .with_kernel_field(1.3)
                        .psf_with(wl, spacing_m / s as f64, k * s, 1)?
                };
                Ok(p.to_f32())
            })
            .collect()
    }

    /// Blur band `b` of the radiance into `out_band` (the padded output plane), block by block.
    fn blur_band(&self, j: &BandJob<'_>, b: usize, out_band: &mut [f32]) -> Result<()> {
        // `out` is SpectralImage::zeros: no second zeroing pass (that pass only faulted the
        // pages in ahead of the tiles).
        let (conv, k) = (j.conv, j.field.k);
        let (rows, cols) = (j.radiance.rows, j.radiance.cols);
        let plane = rows * cols;
        let wl = j.field.wavelengths[b];
        let psfs = self.band_psfs(j.field, b, j.spacing_m, j.s, j.oversampling)?;
        let src = &j.radiance.data[b * plane..(b + 1) * plane];
        let sc = j.scale[b];
        let shade = j.shade;
        let mut scratch = conv.scratch();
        let mut spec = KernelSpectrum(Vec::new());
        let mut kernel = vec![0.0f32; k * k];
        let mut spec2 = KernelSpectrum(Vec::new());
        let mut blur = |bl: &Block, sp: &KernelSpectrum, scratch: &mut crate::conv::Scratch| {
            let Block { r0, c0, nr, nc, .. } = *bl;
            conv.tile_sum(
                r0,
                c0,
                nr,
                nc,
                &[sp],
                out_band,
                j.win,
                scratch,
                |_, r, dst| {
                    let i0 = (r0 + r) * cols + c0;
                    let row = &src[i0..i0 + nc];
                    match shade {
                        None => dst.iter_mut().zip(row).for_each(|(d, v)| *d = v * sc),
                        Some(sh) => dst
                            .iter_mut()
                            .zip(row)
                            .zip(&sh[i0..i0 + nc])
                            .for_each(|((d, v), w)| *d = v * sc * w),
                    }
                },
            );
        };
        for (rep, mirrors) in j.groups {
            block_kernel(&psfs, rep, k, j.s, &mut kernel).map_err(|_| {
                OpticsError::Input(format!(
                    "the field PSF at {wl} nm has no energy inside the {k} x {k} kernel"
                ))
            })?;
            conv.kernel_spectrum_in(&kernel, &mut scratch, &mut spec);
            blur(rep, &spec, &mut scratch);
            for (bl, fx, fy) in mirrors {
                flip_spectrum(&spec, &mut spec2, conv.f, j.phase, *fx, *fy);
                blur(bl, &spec2, &mut scratch);
            }
        }
        out_band.iter_mut().for_each(|v| *v = v.max(0.0));
        Ok(())
    }

    /// The shift-variant optics stage (`Optics::compute` with `blur.method = "shift-variant"`):
    /// `scale` per band is the camera equation's factor, `spacing_m` the sensor-plane sample
    /// spacing, `v_s_m` the image distance, `d_obj_m` the object distance (infinite allowed).
    /// Returns the blurred, padded irradiance and its padding (rows, cols), for
    /// `Optics::finish`, and the geometric map (with the lens's distortion as the resampling
    /// applies it).
    pub(crate) fn compute(
        &self,
        job: &SvJob<'_>,
        radiance: &SpectralImage,
        scale: &[f32],
        spacing_m: f64,
        v_s_m: f64,
        d_obj_m: f64,
    ) -> Result<(SpectralImage, (usize, usize), ImageMap)> {
        let cfg = job.config;
        if radiance.depth_m.is_some() && cfg.focus_distance_m.is_some() {
            return Err(OpticsError::config(
                "blur.method",
                "\"shift-variant\" does not combine with depth-layered defocus (a depth map with focus_distance_m) yet",
            ));
        }
        let (rows, cols) = (radiance.rows, radiance.cols);
        let geo = Geometry { d_obj_m, v_s_m };
        let field = self.field_model(job, radiance, spacing_m, &geo)?;
        let k = field.k;
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
        let mut out = SpectralImage::zeros(
            out_rows,
            out_cols,
            radiance.grid,
            spacing_m,
            Quantity::Irradiance,
        )?;
        let out_half_diag_m = 0.5 * (out_rows as f64).hypot(out_cols as f64) * spacing_m;
        let maps = match (&field.cam, &field.rtf) {
            (Some(cam), _) => Some(self.lens_maps(cam, &geo, out_half_diag_m)?),
            (None, Some((l, dz, _))) => {
                Some(l.maps(v_s_m * 1e3, d_obj_m * 1e3, *dz, out_half_diag_m)?)
            }
            (None, None) => None,
        };
        let shade = if maps.is_some() {
            None
        } else {
            (job.shading)()
        };
        let symmetric = field.rtf.is_none()
            && field.measured.is_none()
            && field
                .wfs
                .iter()
                .flatten()
                .all(|w| w.is_rotationally_symmetric());
        let conv = self.convolver(k);
        // A model whose field PSFs are mirror-symmetric about the meridian (no odd-in-tangential
        // Zernike terms: m < 0) gives mirror-image kernels at mirror-image blocks; with the blocks
        // laid out symmetrically about the axis, one kernel spectrum serves up to four blocks
        // (`flip_spectrum`). The RTF's spots are traced, not symmetrized: each block its own.
        let mirrored = field.rtf.is_none()
            && field.measured.is_none()
            && field.wfs.iter().flatten().all(meridional);
        let groups = block_groups(
            rows,
            cols,
            conv.t,
            mirrored,
            self.field_heights,
            field.half_diag_m,
            spacing_m,
        );
        let phase = flip_phases(k, conv.f);
        let s = if symmetric {
            1
        } else {
            self.rotation_oversampling
        };
        let win = OutputWindow {
            rows: out_rows,
            cols: out_cols,
            off_r: pad_r as isize,
            off_c: pad_c as isize,
        };
        let ctx = BandJob {
            field: &field,
            groups: &groups,
            conv: &conv,
            phase: &phase,
            s,
            oversampling: cfg.psf.oversampling,
            shade: shade.as_deref(),
            win,
            radiance,
            scale,
            spacing_m,
        };
        out.data
            .par_chunks_mut(out_rows * out_cols)
            .enumerate()
            .try_for_each(|(b, out_band)| self.blur_band(&ctx, b, out_band))?;
        if let Some(m) = &maps {
            apply_lens_maps(&mut out, m, spacing_m);
        }
        // Ghosts of the brightest sources, on the padded image centred on the axis.
        if let (Some(g), Some(cam), FieldSource::Lens(lens)) =
            (&self.ghosts, &field.cam, &self.source)
        {
            lens.add_ghosts(cam, g, &mut out)?;
        }
        let map = ImageMap::new(
            rows,
            cols,
            out_rows,
            out_cols,
            maps.as_ref()
                .map(|m| RadialLut::new(m, out_rows, out_cols, spacing_m)),
        );
        Ok((out, (pad_r, pad_c), map))
    }
}
