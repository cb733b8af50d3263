//! The optics stage: scene radiance -> sensor irradiance.

use crate::config::*;
use crate::conv::{Fft2, KernelSpectrum, OutputWindow, TileConvolver};
use crate::error::{OpticsError, Result};
use crate::image_map::ImageMap;
use crate::lens;
use crate::psf::{MtfCurve, Psf};
use crate::shading::{horner, row_coefficients, ShadingChannel, ShadingFit};
use crate::shift_variant::{ShiftVariant, SvJob};
use crate::tail::{self, FarTail};
use crate::wavefront::Wavefront;
use camsim_core::image::ImageGeometry;
use camsim_core::{Quantity, SpectralImage, Spectrum};
use rayon::prelude::*;

/// Shading applied before the blur (relative illumination, fraction).
#[derive(Debug, Clone)]
pub enum ShadingModel {
    /// None.
    None,
    /// cos^4 of the field angle from the exit pupil: cos theta = z / sqrt(z^2 + r^2), z the image
    /// distance, r the field height (ISETCam `opticsCos4`).
    Cos4,
    /// Relative illumination against field height (m, or normalized to the half-diagonal).
    Table {
        /// Field heights (m, or normalized).
        heights: Vec<f64>,
        /// Relative illumination.
        ri: Vec<f64>,
        /// Heights are normalized to the image half-diagonal.
        normalized: bool,
    },
    /// A flat-field fit.
    Fit(ShadingFit, ShadingChannel),
}

/// The optics stage, built from an [`OpticsConfig`].
#[derive(Debug, Clone)]
pub struct Optics {
    config: OpticsConfig,
    wavefront: Wavefront,
    transmittance: Option<Spectrum>,
    scalar_transmittance: f64,
    /// Transmitted area of the pupil's shape / the circle's (1 for the circle).
    aperture_area_fraction: f64,
    /// The glare spread function (`[glare]`), if set.
    glare: Option<crate::glare::GlareSpread>,
    shading: ShadingModel,
    shift_variant: Option<ShiftVariant>,
}

/// How a depth map was split into layers (for reports and tests).
#[derive(Debug, Clone, PartialEq)]
pub struct DepthLayers {
    /// Defocus c4 over the lens pupil of each layer, um (multiples of `step_um`).
    pub c4_um: Vec<f64>,
    /// Layer index of every pixel, row-major.
    pub index: Vec<u16>,
    /// Layer width in c4, um.
    pub step_um: f64,
}

/// Largest fine PSF grid side (samples) for the whole-image OTF path of [`Optics::compute`].
const WHOLE_IMAGE_MAX_FINE: usize = 2048;

fn interp_hold(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    if x <= xs[0] {
        return ys[0];
    }
    if x >= xs[xs.len() - 1] {
        return ys[ys.len() - 1];
    }
    let i = xs.partition_point(|v| *v < x);
    let t = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
    ys[i - 1] * (1.0 - t) + ys[i] * t
}

fn check_increasing(key: &str, xs: &[f64]) -> Result<()> {
    if xs.iter().any(|v| !v.is_finite()) || xs.windows(2).any(|p| p[1] <= p[0]) {
        return Err(OpticsError::config(
            key,
            "values must be finite and strictly increasing",
        ));
    }
    Ok(())
}

/// Fills a band's output plane before the blur adds to it (band index, plane).
type BandInit<'a> = dyn Fn(usize, &mut [f32]) + Sync + 'a;

impl Optics {
    /// Build the optics from a config, checking every value.
    pub fn from_config(config: &OpticsConfig) -> Result<Optics> {
        let c = config;
        if !(c.f_number > 0.0 && c.f_number.is_finite()) {
            return Err(OpticsError::config(
                "f_number",
                format!("{} is not a positive number", c.f_number),
            ));
        }
        if !(c.focal_length_mm > 0.0 && c.focal_length_mm.is_finite()) {
            return Err(OpticsError::config(
                "focal_length_mm",
                format!("{} mm is not a positive number", c.focal_length_mm),
            ));
        }
        let f_m = c.focal_length_mm * 1e-3;
        let (transmittance, scalar_transmittance) = match &c.transmittance {
            Transmittance::Scalar(t) => {
                if !(0.0..=1.0).contains(t) {
                    return Err(OpticsError::config(
                        "transmittance",
                        format!("{t} is not a fraction in [0, 1]"),
                    ));
                }
                (None, *t)
            }
            Transmittance::Spectrum(s) => {
                let sp = Spectrum::new(
                    s.wavelengths_nm.clone(),
                    s.values.clone(),
                    "optics config key `transmittance`",
                )?;
                if let Some(v) = sp.values.iter().find(|v| !(0.0..=1.0).contains(*v)) {
                    return Err(OpticsError::config(
                        "transmittance.values",
                        format!("{v} is not a fraction in [0, 1]"),
                    ));
                }
                (
                    Some(sp.with_extrapolation(camsim_core::spectrum::Extrapolation::Hold)),
                    1.0,
                )
            }
        };
        let w = &c.wavefront;
        let lens_pupil_m = f_m / c.f_number;
        let meas_m = match w.measurement_pupil_mm {
            Some(mm) => mm * 1e-3,
            None => lens_pupil_m,
        };
        let mut wavefront = Wavefront::diffraction_limited(f_m, c.f_number)?
            .with_zernike(w.zernike_um.to_dense()?, meas_m)?
            .with_reference_wavelength(w.reference_wavelength_nm)?
            .with_min_pupil_samples(c.psf.min_pupil_samples);
        if !(c.crosstalk_sigma_um >= 0.0 && c.crosstalk_sigma_um.is_finite()) {
            return Err(OpticsError::config(
                "crosstalk_sigma_um",
                format!("{} is not a number >= 0", c.crosstalk_sigma_um),
            ));
        }
        wavefront = wavefront.with_crosstalk_sigma_m(c.crosstalk_sigma_um * 1e-6);
        if let Some(o) = &c.olpf {
            o.validate()?;
        }
        if let Some(ac) = &c.aperture {
            if c.blur
                .as_ref()
                .is_some_and(|b| b.method == crate::config::BlurKind::ShiftVariant)
            {
                return Err(OpticsError::config(
                    "aperture",
                    "a shaped aperture is not supported with blur.method = \"shift-variant\" yet (its PSFs are rotated per block azimuth, the iris is not)",
                ));
            }
            wavefront = wavefront.with_aperture(aperture_from_config(ac)?);
        }
        if let Some(fc) = &c.flare {
            if c.blur
                .as_ref()
                .is_some_and(|b| b.method == crate::config::BlurKind::ShiftVariant)
            {
                return Err(OpticsError::config(
                    "flare",
                    "pupil flare is not supported with blur.method = \"shift-variant\" yet (its PSFs are rotated per block azimuth, the pattern is not)",
                ));
            }
            wavefront = wavefront.with_flare(flare_from_config(fc, lens_pupil_m)?);
        }
        // The shaped and contaminated pupil's transmitted fraction (the aperture's area fraction
        // alone without flare, as before).
        let aperture_area_fraction = if wavefront.flare().is_some() {
            wavefront.transmitted_fraction()
        } else {
            wavefront.aperture().area_fraction()
        };
        let glare = c
            .glare
            .map(|g| {
                crate::glare::GlareSpread::new(g.fraction, g.exponent, g.core_radius_um * 1e-6)
            })
            .transpose()?;
        if let Some(cd) = &w.chromatic_defocus {
            let s = Spectrum::new(
                cd.wavelengths_nm.clone(),
                cd.c4_um.clone(),
                "optics config key `wavefront.chromatic_defocus`",
            )?;
            wavefront = wavefront.with_chromatic_defocus(s);
        }
        if let Some(d) = c.focus_distance_m {
            if !(d > f_m) {
                return Err(OpticsError::config(
                    "focus_distance_m",
                    format!("{d} m must be beyond the focal length ({f_m} m) for a real image"),
                ));
            }
        }
        if !(c.defocus_tolerance_um > 0.0 && c.defocus_tolerance_um.is_finite()) {
            return Err(OpticsError::config(
                "defocus_tolerance_um",
                format!("{} is not a positive number", c.defocus_tolerance_um),
            ));
        }
        if c.max_depth_layers == 0 || c.max_depth_layers > 4096 {
            return Err(OpticsError::config(
                "max_depth_layers",
                format!("{} must be 1..=4096", c.max_depth_layers),
            ));
        }
        if c.psf.oversampling == 0 || c.psf.oversampling > 63 {
            return Err(OpticsError::config(
                "psf.oversampling",
                format!("{} must be 1..=63", c.psf.oversampling),
            ));
        }
        if !(c.psf.tail_energy > 0.0 && c.psf.tail_energy < 0.5) {
            return Err(OpticsError::config(
                "psf.tail_energy",
                format!("{} must be in (0, 0.5)", c.psf.tail_energy),
            ));
        }
        if c.psf.max_kernel_size < 3 || c.psf.max_kernel_size > 4095 {
            return Err(OpticsError::config(
                "psf.max_kernel_size",
                format!("{} must be 3..=4095", c.psf.max_kernel_size),
            ));
        }
        let shading = match &c.shading {
            ShadingConfig::Named(ShadingName::None) => ShadingModel::None,
            ShadingConfig::Named(ShadingName::Cos4) => ShadingModel::Cos4,
            ShadingConfig::Table(t) => {
                let r = &t.relative_illumination;
                let (heights, normalized, key) =
                    match (&r.field_height_mm, &r.field_height_normalized) {
                        (Some(h), None) => (
                            h.iter().map(|v| v * 1e-3).collect::<Vec<_>>(),
                            false,
                            "field_height_mm",
                        ),
                        (None, Some(h)) => (h.clone(), true, "field_height_normalized"),
                        _ => {
                            return Err(OpticsError::config(
                                "shading.relative_illumination",
                                "give exactly one of field_height_mm or field_height_normalized",
                            ))
                        }
                    };
                let key = format!("shading.relative_illumination.{key}");
                check_increasing(&key, &heights)?;
                if heights.is_empty() || heights.len() != r.ri.len() {
                    return Err(OpticsError::config(
                        key,
                        format!("{} heights but {} ri values", heights.len(), r.ri.len()),
                    ));
                }
                if let Some(v) = r.ri.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
                    return Err(OpticsError::config(
                        "shading.relative_illumination.ri",
                        format!("{v} is not a non-negative number"),
                    ));
                }
                ShadingModel::Table {
                    heights,
                    ri: r.ri.clone(),
                    normalized,
                }
            }
            ShadingConfig::File(f) => ShadingModel::Fit(ShadingFit::from_file(&f.file)?, f.channel),
        };
        let shift_variant = match &c.blur {
            Some(b) => ShiftVariant::from_config(
                b,
                c.f_number,
                c.focal_length_mm,
                matches!(c.shading, ShadingConfig::Named(ShadingName::None)),
            )?,
            None => None,
        };
        Ok(Optics {
            config: config.clone(),
            wavefront,
            transmittance,
            scalar_transmittance,
            aperture_area_fraction,
            glare,
            shading,
            shift_variant,
        })
    }

    /// A built-in preset (`pixel4a`, `pixel4a-measured`, `diffraction-limited`).
    pub fn preset(name: &str) -> Result<Optics> {
        Optics::from_config(&OpticsConfig::preset(name)?)
    }

    /// The configuration.
    pub fn config(&self) -> &OpticsConfig {
        &self.config
    }

    /// The wavefront model (lens focused at its configured focus, object in focus).
    pub fn wavefront(&self) -> &Wavefront {
        &self.wavefront
    }

    /// Transmitted area of the pupil's shape as a fraction of the circle of diameter
    /// focal length / f-number (1 without `aperture`), times the flare's transmission with
    /// `flare` ([`Wavefront::transmitted_fraction`]); the irradiance is scaled by it.
    pub fn aperture_area_fraction(&self) -> f64 {
        self.aperture_area_fraction
    }

    /// The shading model.
    pub fn shading(&self) -> &ShadingModel {
        &self.shading
    }

    /// Lens transmittance at `wavelength_nm` (fraction).
    pub fn transmittance(&self, wavelength_nm: f64) -> f64 {
        match &self.transmittance {
            Some(s) => s.eval(wavelength_nm),
            None => self.scalar_transmittance,
        }
    }

    fn focal_m(&self) -> f64 {
        self.config.focal_length_mm * 1e-3
    }

    /// Thin-lens defocus c4 (um, over the lens pupil) of an object at `object_distance_m` with the
    /// lens focused at `focus_distance_m` ([`lens::defocus_c4_um`]).
    pub fn defocus_c4_um(&self, focus_distance_m: f64, object_distance_m: f64) -> f64 {
        lens::defocus_c4_um(
            self.focal_m(),
            self.config.f_number,
            focus_distance_m,
            object_distance_m,
        )
    }

    /// The wavefront for an object at `object_distance_m` (<= 0 or infinite: infinity) with the
    /// lens focused at `focus_distance_m` (None: focused on the object): image distance at the
    /// focus, plus the thin-lens focus error as extra defocus.
    pub fn wavefront_for(
        &self,
        focus_distance_m: Option<f64>,
        object_distance_m: f64,
    ) -> Result<Wavefront> {
        let f = self.focal_m();
        let focus = focus_distance_m.unwrap_or(object_distance_m);
        let v = lens::image_distance_m(f, focus).ok_or_else(|| {
            OpticsError::Input(format!(
                "focus distance {focus} m is inside the focal length {f} m"
            ))
        })?;
        let extra = match focus_distance_m {
            Some(fd) => self.defocus_c4_um(fd, object_distance_m),
            None => 0.0,
        };
        Ok(self
            .wavefront
            .clone()
            .with_image_distance(v)
            .with_extra_defocus_um(extra))
    }

    /// PSFs at `wavelengths_nm` sampled at `spacing_m` (sensor plane), for an object in focus,
    /// all with the same (automatic) odd size.
    pub fn psf_stack(&self, wavelengths_nm: &[f64], spacing_m: f64) -> Result<Vec<Psf>> {
        self.psf_stack_for(&self.wavefront, wavelengths_nm, spacing_m)
    }

    /// [`Self::psf_stack`] for a given wavefront (e.g. from [`Self::wavefront_for`]).
    pub fn psf_stack_for(
        &self,
        wf: &Wavefront,
        wavelengths_nm: &[f64],
        spacing_m: f64,
    ) -> Result<Vec<Psf>> {
        let size = wavelengths_nm
            .iter()
            .map(|w| wf.kernel_size(*w, spacing_m, self.config.psf.tail_energy))
            .max()
            .unwrap_or(1)
            .min(self.max_kernel());
        wavelengths_nm
            .par_iter()
            .map(|w| wf.psf_with(*w, spacing_m, size, self.config.psf.oversampling))
            .collect()
    }

    /// MTF curves (cycles/mm in the sensor plane) per wavelength, object in focus.
    pub fn mtf_curves(&self, wavelengths_nm: &[f64]) -> Result<Vec<MtfCurve>> {
        wavelengths_nm
            .par_iter()
            .map(|w| self.wavefront.mtf(*w))
            .collect()
    }

    fn max_kernel(&self) -> usize {
        let m = self.config.psf.max_kernel_size;
        if m.is_multiple_of(2) {
            m - 1
        } else {
            m
        }
    }

    /// Split a depth map (m) into defocus layers for a lens focused at `focus_distance_m`: each
    /// pixel's thin-lens c4 is rounded to a multiple of the tolerance (so c4 = 0, the focal plane,
    /// is always a layer centre and every pixel's defocus is within tolerance / 2 of its layer's);
    /// when that gives more than `max_depth_layers` layers the step grows until it fits.
    /// Depth must be > 0 (infinity allowed); NaN or <= 0 is an error naming the pixel.
    pub fn depth_layers(
        &self,
        depth_m: &[f32],
        cols: usize,
        focus_distance_m: f64,
    ) -> Result<DepthLayers> {
        let mut c4 = Vec::with_capacity(depth_m.len());
        for (i, d) in depth_m.iter().enumerate() {
            let d = *d as f64;
            if !(d > 0.0) {
                return Err(OpticsError::Input(format!(
                    "depth map value {d} m at row {}, column {} is not a positive distance",
                    i / cols.max(1),
                    i % cols.max(1)
                )));
            }
            c4.push(self.defocus_c4_um(focus_distance_m, d));
        }
        let (lo, hi) = c4
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        let mut step = self.config.defocus_tolerance_um;
        let max_layers = self.config.max_depth_layers as i64;
        loop {
            let (a, b) = ((lo / step).round() as i64, (hi / step).round() as i64);
            if b - a < max_layers {
                break;
            }
            step *= 1.25;
        }
        let base = (lo / step).round() as i64;
        let top = (hi / step).round() as i64;
        let mut used = vec![false; (top - base + 1).max(1) as usize];
        let raw_idx: Vec<usize> = c4
            .iter()
            .map(|v| {
                let k = ((v / step).round() as i64 - base) as usize;
                used[k] = true;
                k
            })
            .collect();
        // Compact to the layers present.
        let mut remap = vec![u16::MAX; used.len()];
        let mut layers = Vec::new();
        for (k, u) in used.iter().enumerate() {
            if *u {
                remap[k] = layers.len() as u16;
                layers.push((k as i64 + base) as f64 * step);
            }
        }
        Ok(DepthLayers {
            c4_um: layers,
            index: raw_idx.iter().map(|k| remap[*k]).collect(),
            step_um: step,
        })
    }

    pub(crate) fn shading_map(
        &self,
        rows: usize,
        cols: usize,
        spacing_m: f64,
        image_distance_m: f64,
    ) -> Option<Vec<f32>> {
        let cx = cols as f64 / 2.0;
        let cy = rows as f64 / 2.0;
        let half_diag = (cx * cx + cy * cy).sqrt() * spacing_m;
        let mut map = vec![0.0f32; rows * cols];
        match &self.shading {
            ShadingModel::None => return None,
            ShadingModel::Cos4 => {
                map.par_chunks_mut(cols).enumerate().for_each(|(r, row)| {
                    let y = (r as f64 + 0.5 - cy) * spacing_m;
                    for (c, v) in row.iter_mut().enumerate() {
                        let x = (c as f64 + 0.5 - cx) * spacing_m;
                        // cos^4 theta with cos^2 theta = z^2 / (z^2 + r^2) (ISETCam opticsCos4).
                        let c2 = image_distance_m * image_distance_m
                            / (image_distance_m * image_distance_m + x * x + y * y);
                        *v = (c2 * c2) as f32;
                    }
                });
            }
            ShadingModel::Table {
                heights,
                ri,
                normalized,
            } => {
                map.par_chunks_mut(cols).enumerate().for_each(|(r, row)| {
                    let y = (r as f64 + 0.5 - cy) * spacing_m;
                    for (c, v) in row.iter_mut().enumerate() {
                        let x = (c as f64 + 0.5 - cx) * spacing_m;
                        let mut h = (x * x + y * y).sqrt();
                        if *normalized {
                            h /= half_diag;
                        }
                        *v = interp_hold(heights, ri, h) as f32;
                    }
                });
            }
            ShadingModel::Fit(fit, which) => {
                let chans: Vec<camsim_core::CfaChannel> = match which {
                    ShadingChannel::Mean => vec![
                        camsim_core::CfaChannel::R,
                        camsim_core::CfaChannel::G,
                        camsim_core::CfaChannel::B,
                    ],
                    ShadingChannel::R => vec![camsim_core::CfaChannel::R],
                    ShadingChannel::G => vec![camsim_core::CfaChannel::G],
                    ShadingChannel::B => vec![camsim_core::CfaChannel::B],
                };
                map.par_chunks_mut(cols).enumerate().for_each(|(r, row)| {
                    let y = (r as f64 + 0.5) / rows as f64 * 2.0 - 1.0;
                    let rc: Vec<Vec<f64>> = chans
                        .iter()
                        .map(|ch| row_coefficients(fit.coefficients(*ch), fit.order, y))
                        .collect();
                    for (c, v) in row.iter_mut().enumerate() {
                        let x = (c as f64 + 0.5) / cols as f64 * 2.0 - 1.0;
                        let s: f64 =
                            rc.iter().map(|cx| horner(cx, x)).sum::<f64>() / rc.len() as f64;
                        *v = s.max(0.0) as f32;
                    }
                });
            }
        }
        Some(map)
    }

    /// Sensor-plane spectral irradiance, W/(m^2 nm), from scene spectral radiance, W/(sr m^2 nm).
    ///
    /// 1. Geometry (thin lens): object distance d = `geometry.distance_m` (0 or infinite: at
    ///    infinity); the lens is focused at `focus_distance_m`, or on the scene when unset; sensor at
    ///    v = 1/(1/f - 1/d_focus). Sample spacing in the sensor plane: scene spacing x v / d, or for
    ///    a scene at infinity 2 v tan(fov/2) / cols.
    /// 2. E = pi T(lambda) / (1 + 4 N^2 (1 + |m|)^2) L, m = v_obj / d (ISETCam `oiCalculateIrradiance`),
    ///    times the shading (cos^4, table or fit; evaluated at the scene samples' sensor positions).
    /// 3. Blur per band with the wavefront PSF. `psf.method = "auto"` (default), no depth layers and
    ///    a small image: the whole-image OTF (ISETCam `opticsOTF`: the image's spectrum times the
    ///    DFT of the untrimmed, periodized PSF, [`Wavefront::psf_periodic`], on an FFT plane twice
    ///    the output so nothing wraps); light beyond the output margin leaves the image. Otherwise
    ///    (see [`Wavefront::psf`]) by tiled FFT convolution
    ///    (overlap-add, zero padded, no wrap-around), rayon over bands, FFT plans shared; one kernel
    ///    side for all bands, set by `psf.tail_energy` at the longest wavelength. With
    ///    `psf.far_tail` (default) the kernel carries 1 - e of the energy and the diffraction tail
    ///    beyond its window (energy e) is added on a coarse grid ([`crate::tail`]), so large
    ///    images get their patches' far light as the whole-image OTF gives it. Negative FFT
    ///    round-off is clamped to 0.
    ///    With a depth map and `focus_distance_m`: depth layers ([`Self::depth_layers`]); the result
    ///    is the sum over layers of PSF_layer * (E x mask_layer), summed per tile in the frequency
    ///    domain. Each PSF has unit volume, so the composite conserves energy; at occlusion
    ///    boundaries a blurred background spreads over the foreground edge (layers are not
    ///    occluded by nearer layers: the usual layered-defocus approximation).
    /// 4. Borders (`padding`): zero radiance outside the scene; the output grows by the PSF
    ///    half-width ("psf"), by 1/8 of the size ("isetcam") or keeps the scene size ("none").
    ///    `depth_m` is carried through (padding replicates the edge depth).
    pub fn compute(&self, radiance: &SpectralImage) -> Result<SpectralImage> {
        Ok(self.compute_mapped(radiance)?.0)
    }

    /// Per band of `grid`, the largest sensor irradiance per unit scene radiance this lens gives:
    /// the camera equation on axis with the object at infinity, `pi T(lambda) / (1 + 4 N^2)`
    /// (no relative-illumination fall-off, magnification 0), times the shaped aperture's area
    /// fraction; (W m^-2 nm^-1) per (W sr^-1 m^-2 nm^-1), i.e. sr.
    pub fn peak_irradiance_per_radiance(&self, grid: &camsim_core::WavelengthGrid) -> Vec<f64> {
        (0..grid.len())
            .map(|b| {
                lens::irradiance_factor(
                    self.config.f_number,
                    0.0,
                    self.transmittance(grid.wavelength_nm(b)),
                ) * self.aperture_area_fraction
            })
            .collect()
    }

    /// [`Self::compute`] with its geometric map: where each irradiance sample images from in the
    /// radiance ([`ImageMap`]).
    pub fn compute_mapped(&self, radiance: &SpectralImage) -> Result<(SpectralImage, ImageMap)> {
        let (mut img, map) = self.compute_lens(radiance)?;
        // The optical low-pass filter sits between the lens and the sensor: its spots are
        // displaced in the sensor plane, after every lens effect.
        if let Some(olpf) = &self.config.olpf {
            crate::olpf::apply(&mut img, olpf)?;
        }
        Ok((img, map))
    }

    /// The lens's irradiance (everything of [`Self::compute_mapped`] but the low-pass filter).
    fn compute_lens(&self, radiance: &SpectralImage) -> Result<(SpectralImage, ImageMap)> {
        if radiance.quantity != Quantity::Radiance {
            return Err(OpticsError::Input(format!(
                "expected a radiance image, got {}",
                radiance.quantity.name()
            )));
        }
        let (rows, cols) = (radiance.rows, radiance.cols);
        if radiance.data.len() != rows * cols * radiance.bands() {
            return Err(OpticsError::Input(
                "radiance data length does not match rows x cols x bands".into(),
            ));
        }
        let f = self.focal_m();
        let n = self.config.f_number;
        let d_raw = radiance.geometry.distance_m;
        let d_obj = if d_raw > 0.0 && d_raw.is_finite() {
            d_raw
        } else {
            f64::INFINITY
        };
        if d_obj <= f {
            return Err(OpticsError::Input(format!(
                "scene distance {d_obj} m is inside the focal length {f} m"
            )));
        }
        let focus = self.config.focus_distance_m.unwrap_or(d_obj);
        let v_s = lens::image_distance_m(f, focus).unwrap_or(f);
        let spacing = if d_obj.is_finite() {
            radiance.sample_spacing_m * v_s / d_obj
        } else if radiance.geometry.fov_deg > 0.0 && radiance.geometry.fov_deg < 180.0 {
            2.0 * v_s * (radiance.geometry.fov_deg.to_radians() / 2.0).tan() / cols as f64
        } else {
            return Err(OpticsError::Input(
                "the scene has neither a distance (geometry.distance_m) nor a field of view (geometry.fov_deg)".into(),
            ));
        };
        let m = lens::magnification(f, d_obj);
        let bands = radiance.bands();
        let grid = radiance.grid;
        let scale: Vec<f32> = (0..bands)
            .map(|b| {
                // The camera equation's pi / (4 N^2) is for the circle of diameter f / N; a shaped
                // aperture passes its area fraction of that light.
                (lens::irradiance_factor(n, m, self.transmittance(grid.wavelength_nm(b)))
                    * self.aperture_area_fraction) as f32
            })
            .collect();
        if let Some(sv) = &self.shift_variant {
            return self.compute_shift_variant(sv, radiance, &scale, spacing, v_s, d_obj);
        }

        // Defocus: depth layers, or one wavefront for the whole image.
        let layered = match (&radiance.depth_m, self.config.focus_distance_m) {
            (Some(depth), Some(fd)) => {
                if depth.len() != rows * cols {
                    return Err(OpticsError::Input(format!(
                        "depth map has {} values for {rows} x {cols}",
                        depth.len()
                    )));
                }
                Some(self.depth_layers(depth, cols, fd)?)
            }
            _ => None,
        };
        let base = self.wavefront.clone().with_image_distance(v_s);
        let wavefronts: Vec<Wavefront> = match &layered {
            Some(l) => l
                .c4_um
                .iter()
                .map(|c4| base.clone().with_extra_defocus_um(*c4))
                .collect(),
            None => {
                let extra = match self.config.focus_distance_m {
                    Some(fd) => self.defocus_c4_um(fd, d_obj),
                    None => 0.0,
                };
                vec![base.clone().with_extra_defocus_um(extra)]
            }
        };
        // One kernel side for every band: the largest over bands and layers. (A side per band at
        // the same `psf.tail_energy` would be ~6 % faster, since the diffraction tail grows with
        // wavelength, but trims the blue and green tails to the tolerance: in the Cornell box the
        // saturated lamp's flare then shifts dim regions' R/G by 3-5 %.)
        let tail = self.config.psf.tail_energy;
        let k_wanted = wavefronts
            .par_iter()
            .map(|w| {
                (0..bands)
                    .map(|b| w.kernel_size(grid.wavelength_nm(b), spacing, tail))
                    .max()
                    .unwrap_or(1)
            })
            .max()
            .unwrap_or(1);
        let k = k_wanted.min(self.max_kernel());
        let h = k / 2;
        let (pad_r, pad_c) = match self.config.padding {
            Padding::Psf => (h, h),
            Padding::Isetcam => (
                ((rows as f64) / 8.0).round() as usize,
                ((cols as f64) / 8.0).round() as usize,
            ),
            Padding::None => (0, 0),
        };
        let (out_rows, out_cols) = (rows + 2 * pad_r, cols + 2 * pad_c);
        // The stage's peak, before any of it is allocated: the irradiance cube, the shading map,
        // and per worker one band in flight: on the FFT plane for the whole-image OTF (f64 plane
        // and complex spectrum, 24 bytes a sample; only small images take that path) or padded by
        // the kernel for the kernel blur (f32 in and out).
        let side = crate::wavefront::fast_fft_len(2 * out_rows.max(out_cols));
        let per_band = if side <= WHOLE_IMAGE_MAX_FINE {
            side * side * 24
        } else {
            (out_rows + k) * (out_cols + k) * 8
        };
        camsim_core::mem::MemoryBudget::new(format!(
            "the optics stage ({out_rows} x {out_cols} x {bands} bands)"
        ))
        .f32s("irradiance cube", out_rows * out_cols * bands)
        .f32s("shading map", rows * cols)
        .bytes(
            "bands in flight",
            (rayon::current_num_threads().min(bands) * per_band) as u64,
        )
        .check("use a smaller scene (rows, cols), fewer wavelengths or fewer threads")?;
        let mut out =
            SpectralImage::zeros(out_rows, out_cols, grid, spacing, Quantity::Irradiance)?;
        let shade = self.shading_map(rows, cols, spacing, v_s);

        // Small images without depth layers: the whole-image OTF blur (ISETCam opticsOTF): the
        // image's spectrum times the OTF at its own frequencies (the DFT of the PSF periodized on
        // the FFT plane, Wavefront::psf_periodic), so no kernel trims the tail and every patch gets
        // all of its neighbours' tail light. Unlike ISETCam the FFT plane is the output plus zeros
        // of half its size on each side (period 2x the output), so the light that leaves the
        // output does not wrap around onto the opposite edge (on a 4 x 6 patch chart at 1.4 um that
        // wrap brightened a dark corner patch by 0.7 %). The cost is the fine PSF grid (side k_os x
        // the FFT period, k_os the cell oversampling): used while it is <= WHOLE_IMAGE_MAX_FINE
        // (a 142 x 142 x 31 output at 1.4 um, k_os = 5: 0.15 s against 0.04 s with kernels).
        let oversampling = self.config.psf.oversampling;
        let k_os = (0..bands)
            .map(|b| base.oversampling(grid.wavelength_nm(b), spacing, oversampling))
            .max()
            .unwrap_or(1);
        // A square FFT plane (the periodic PSF is then exact, see Wavefront::psf_periodic) of a fast
        // FFT length >= twice the output's longer side.
        let fft_side = crate::wavefront::fast_fft_len(2 * out_rows.max(out_cols));
        let (fft_rows, fft_cols) = (fft_side, fft_side);
        let (ext_r, ext_c) = ((fft_rows - out_rows) / 2, (fft_cols - out_cols) / 2);
        let whole = match self.config.psf.method {
            BlurMethod::Auto => {
                layered.is_none() && fft_rows.max(fft_cols) * k_os <= WHOLE_IMAGE_MAX_FINE
            }
            BlurMethod::Otf => {
                if layered.is_some() {
                    return Err(OpticsError::config("psf.method", "\"otf\" blurs with one PSF; a depth map with focus_distance_m needs \"auto\" or \"kernel\""));
                }
                if fft_side * k_os > crate::wavefront::MAX_PSF_FFT {
                    return Err(OpticsError::config(
                        "psf.method",
                        format!(
                            "\"otf\" needs a {n} x {n} PSF grid for this {out_rows} x {out_cols} output (at most {}); use \"auto\" or \"kernel\"",
                            crate::wavefront::MAX_PSF_FFT,
                            n = fft_side * k_os
                        ),
                    ));
                }
                true
            }
            BlurMethod::Kernel => false,
        };
        if whole {
            let wf = &wavefronts[0];
            let fft = Fft2::new(fft_rows, fft_cols);
            out.data
                .par_chunks_mut(out_rows * out_cols)
                .enumerate()
                .try_for_each(|(b, out_band)| -> Result<()> {
                    let src = &radiance.data[b * rows * cols..(b + 1) * rows * cols];
                    let sc = scale[b] as f64;
                    let (off_r, off_c) = (ext_r + pad_r, ext_c + pad_c);
                    let mut plane = vec![0.0f64; fft_rows * fft_cols];
                    for r in 0..rows {
                        let dst = &mut plane
                            [(r + off_r) * fft_cols + off_c..(r + off_r) * fft_cols + off_c + cols];
                        for (c, d) in dst.iter_mut().enumerate() {
                            let w = shade
                                .as_ref()
                                .map(|s| s[r * cols + c] as f64)
                                .unwrap_or(1.0);
                            *d = src[r * cols + c] as f64 * sc * w;
                        }
                    }
                    let psf = wf.psf_periodic(
                        grid.wavelength_nm(b),
                        spacing,
                        fft_rows,
                        fft_cols,
                        oversampling,
                    )?;
                    let otf = fft.forward(&psf);
                    let mut spec = fft.forward(&plane);
                    spec.iter_mut().zip(&otf).for_each(|(s, o)| *s *= *o);
                    let blurred = fft.inverse(spec);
                    // Round-off leaves samples of either sign near 1e-16 of the maximum: clamp at 0.
                    for (r, orow) in out_band.chunks_exact_mut(out_cols).enumerate() {
                        let brow = &blurred[(r + ext_r) * fft_cols + ext_c
                            ..(r + ext_r) * fft_cols + ext_c + out_cols];
                        orow.iter_mut()
                            .zip(brow)
                            .for_each(|(o, v)| *o = v.max(0.0) as f32);
                    }
                    Ok(())
                })?;
        } else if self.config.psf.far_tail && k == k_wanted {
            // Kernels plus the far tail (crate::tail): the kernel carries 1 - e of each band's
            // energy, the coarse-grid tail the rest. (A kernel clamped by max_kernel_size does
            // not reach past the geometric blur, where the tail's asymptote holds: no tail then.)
            let far = FarTail::new(out_rows, out_cols, k / 2);
            let n_w = base.working_f_number();
            let amp: Vec<f64> = (0..bands)
                .map(|b| tail::tail_amplitude(grid.wavelength_nm(b), n_w, spacing))
                .collect();
            let near: Vec<f32> = scale
                .iter()
                .zip(&amp)
                .map(|(s, a)| (*s as f64 * (1.0 - far.energy(*a))) as f32)
                .collect();
            let plane = rows * cols;
            let far_band = |b: usize, out_band: &mut [f32]| {
                let src = &radiance.data[b * plane..(b + 1) * plane];
                far.write_band(
                    src,
                    rows,
                    cols,
                    (pad_r, pad_c),
                    scale[b],
                    shade.as_deref(),
                    amp[b],
                    out_band,
                )
            };
            let init: &(dyn Fn(usize, &mut [f32]) + Sync) = &far_band;
            self.blur_tiled(
                radiance,
                &mut out,
                &wavefronts,
                layered.as_ref(),
                shade.as_deref(),
                &near,
                spacing,
                k,
                (pad_r, pad_c),
                Some(init),
            )?;
        } else {
            self.blur_tiled(
                radiance,
                &mut out,
                &wavefronts,
                layered.as_ref(),
                shade.as_deref(),
                &scale,
                spacing,
                k,
                (pad_r, pad_c),
                None,
            )?;
        }

        self.add_glare(&mut out, spacing)?;
        let map = ImageMap::new(rows, cols, out_rows, out_cols, None);
        Ok((
            self.finish(out, radiance, (pad_r, pad_c), spacing, v_s),
            map,
        ))
    }

    /// The glare spread function of `[glare]`, if set.
    pub fn glare(&self) -> Option<&crate::glare::GlareSpread> {
        self.glare.as_ref()
    }

    /// Veiling glare (`[glare]`, [`crate::glare`]): every band of the blurred irradiance becomes
    /// (1 - G) E + g * E, bands in parallel; nothing without `[glare]`.
    fn add_glare(&self, out: &mut SpectralImage, spacing: f64) -> Result<()> {
        let Some(g) = self.glare else {
            return Ok(());
        };
        let plan = crate::glare::GlarePlan::new(g, out.rows, out.cols, spacing)?;
        let plane = out.rows * out.cols;
        out.data
            .par_chunks_mut(plane)
            .for_each(|band| plan.apply(band));
        Ok(())
    }

    /// The shift-variant model, when `blur.method = "shift-variant"`.
    pub fn shift_variant(&self) -> Option<&ShiftVariant> {
        self.shift_variant.as_ref()
    }

    /// The shift-variant stage ([`crate::shift_variant`]) of [`Optics::compute`]: the on-axis
    /// wavefront at the image distance `v_s` with the focus setting's defocus, the shading map
    /// when the lens has no maps of its own, then [`Optics::finish`].
    fn compute_shift_variant(
        &self,
        sv: &ShiftVariant,
        radiance: &SpectralImage,
        scale: &[f32],
        spacing: f64,
        v_s: f64,
        d_obj: f64,
    ) -> Result<(SpectralImage, ImageMap)> {
        let extra = self
            .config
            .focus_distance_m
            .map(|fd| self.defocus_c4_um(fd, d_obj))
            .unwrap_or(0.0);
        let job = SvJob {
            config: &self.config,
            wavefront: self
                .wavefront
                .clone()
                .with_image_distance(v_s)
                .with_extra_defocus_um(extra),
            shading: &|| self.shading_map(radiance.rows, radiance.cols, spacing, v_s),
        };
        let (mut out, pad, map) = sv.compute(&job, radiance, scale, spacing, v_s, d_obj)?;
        self.add_glare(&mut out, spacing)?;
        Ok((self.finish(out, radiance, pad, spacing, v_s), map))
    }

    /// Step 4 of [`Self::compute`]: carry the depth map (edge-replicated into the padding) and set
    /// the irradiance image's geometry.
    pub(crate) fn finish(
        &self,
        mut out: SpectralImage,
        radiance: &SpectralImage,
        (pad_r, pad_c): (usize, usize),
        spacing: f64,
        v_s: f64,
    ) -> SpectralImage {
        let (rows, cols) = (radiance.rows, radiance.cols);
        let (out_rows, out_cols) = (out.rows, out.cols);
        let f = self.focal_m();
        let n = self.config.f_number;
        if let Some(depth) = &radiance.depth_m {
            let mut dm = vec![0.0f32; out_rows * out_cols];
            for r in 0..out_rows {
                let ir = (r as isize - pad_r as isize).clamp(0, rows as isize - 1) as usize;
                for c in 0..out_cols {
                    let ic = (c as isize - pad_c as isize).clamp(0, cols as isize - 1) as usize;
                    dm[r * out_cols + c] = depth[ir * cols + ic];
                }
            }
            out.depth_m = Some(dm);
        }
        out.geometry = ImageGeometry {
            fov_deg: 2.0 * (out_cols as f64 * spacing / 2.0 / v_s).atan().to_degrees(),
            distance_m: radiance.geometry.distance_m,
            focal_length_m: f,
            f_number: n,
        };
        out
    }

    /// Step 3 by tiled FFT convolution with `k` x `k` kernels (see [`Self::compute`]), added onto
    /// what `init(band, out_band)` writes into each band first (zeros without it).
    #[allow(clippy::too_many_arguments)]
    fn blur_tiled(
        &self,
        radiance: &SpectralImage,
        out: &mut SpectralImage,
        wavefronts: &[Wavefront],
        layered: Option<&DepthLayers>,
        shade: Option<&[f32]>,
        scale: &[f32],
        spacing: f64,
        k: usize,
        (pad_r, pad_c): (usize, usize),
        init: Option<&BandInit<'_>>,
    ) -> Result<()> {
        let (rows, cols) = (radiance.rows, radiance.cols);
        let (out_rows, out_cols) = (out.rows, out.cols);
        let grid = radiance.grid;
        let oversampling = self.config.psf.oversampling;
        let conv = TileConvolver::new(k);
        let t = conv.t;
        let (ntr, ntc) = (rows.div_ceil(t), cols.div_ceil(t));
        // Layers present in each tile.
        let tile_layers: Vec<Vec<u16>> = match layered {
            None => vec![vec![0]; ntr * ntc],
            Some(l) => (0..ntr * ntc)
                .into_par_iter()
                .map(|ti| {
                    let (tr, tc) = (ti / ntc, ti % ntc);
                    let mut seen = vec![false; l.c4_um.len()];
                    for r in tr * t..((tr + 1) * t).min(rows) {
                        for c in tc * t..((tc + 1) * t).min(cols) {
                            seen[l.index[r * cols + c] as usize] = true;
                        }
                    }
                    seen.iter()
                        .enumerate()
                        .filter(|(_, s)| **s)
                        .map(|(i, _)| i as u16)
                        .collect()
                })
                .collect(),
        };
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
                // Touch the band's pages with a write first (zeros or `init`): the allocator hands out
                // lazily mapped zero pages, and the tiles' read-modify-write (`+=`) would fault each
                // page twice (zero-page read, then copy-on-write).
                match init {
                    Some(f) => f(b, out_band),
                    None => out_band.fill(0.0),
                }
                let wl = grid.wavelength_nm(b);
                let src = &radiance.data[b * plane..(b + 1) * plane];
                let sc = scale[b];
                let mut specs = Vec::with_capacity(wavefronts.len());
                for w in wavefronts {
                    let psf = w.psf_with(wl, spacing, k, oversampling)?;
                    specs.push(conv.kernel_spectrum(&psf.to_f32()));
                }
                let mut s = conv.scratch();
                for tr in 0..ntr {
                    for tc in 0..ntc {
                        let (r0, c0) = (tr * t, tc * t);
                        let (nr, nc) = (t.min(rows - r0), t.min(cols - c0));
                        // The depth layers present in this tile: one convolution per layer, summed
                        // in the frequency domain (TileConvolver::tile_sum).
                        let tile_layers = &tile_layers[tr * ntc + tc];
                        let tile_specs: Vec<&KernelSpectrum> =
                            tile_layers.iter().map(|&l| &specs[l as usize]).collect();
                        conv.tile_sum(
                            r0,
                            c0,
                            nr,
                            nc,
                            &tile_specs,
                            out_band,
                            win,
                            &mut s,
                            |i, r, dst| {
                                let i0 = (r0 + r) * cols + c0;
                                let row = &src[i0..i0 + nc];
                                match (shade, layered) {
                                    (None, None) => {
                                        dst.iter_mut().zip(row).for_each(|(d, v)| *d = v * sc)
                                    }
                                    (Some(sh), None) => dst
                                        .iter_mut()
                                        .zip(row)
                                        .zip(&sh[i0..i0 + nc])
                                        .for_each(|((d, v), w)| *d = v * sc * w),
                                    (sh, Some(l)) => {
                                        let layer = tile_layers[i];
                                        let idx = &l.index[i0..i0 + nc];
                                        for j in 0..nc {
                                            let w = sh.as_ref().map(|s| s[i0 + j]).unwrap_or(1.0);
                                            dst[j] = if idx[j] == layer {
                                                row[j] * sc * w
                                            } else {
                                                0.0
                                            };
                                        }
                                    }
                                }
                            },
                        );
                    }
                }
                // FFT round-off leaves samples of either sign around 1e-7 of the maximum; irradiance is
                // non-negative, so clamp at 0 (the in-memory image and every file written from it).
                out_band.iter_mut().for_each(|v| *v = v.max(0.0));
                Ok(())
            })
    }
}

/// The [`Aperture`](crate::aperture::Aperture) of an `[aperture]` config (reads the mask file).
pub fn aperture_from_config(
    ac: &crate::config::ApertureConfig,
) -> Result<crate::aperture::Aperture> {
    let mut a = crate::aperture::Aperture::circle();
    if let Some(n) = ac.blades {
        a = a.with_blades(n, ac.rotation_deg, ac.curvature)?;
    } else if ac.rotation_deg != 0.0 || ac.curvature != 0.0 {
        return Err(OpticsError::config(
            "aperture.blades",
            "rotation_deg and curvature shape an iris: give the blade count too",
        ));
    }
    a = a.with_obstruction(ac.obstruction)?;
    if ac.vanes > 0 || ac.vane_width != 0.0 || ac.vane_rotation_deg != 0.0 {
        if ac.vanes == 0 {
            return Err(OpticsError::config(
                "aperture.vanes",
                "vane_width or vane_rotation_deg given without a vane count",
            ));
        }
        a = a.with_vanes(ac.vanes, ac.vane_width, ac.vane_rotation_deg)?;
    }
    if let Some(p) = &ac.mask {
        a = a.with_mask(crate::aperture::TransmissionMask::from_file(p)?);
    }
    if let Some(h) = ac.half {
        a = a.with_half(h);
    }
    Ok(a)
}

/// The [`PupilFlare`](crate::flare::PupilFlare) of a `[flare]` config for a lens pupil of
/// diameter `pupil_diameter_m` (reads the mask files; sizes normalized by the pupil radius).
pub fn flare_from_config(
    fc: &crate::config::FlareConfig,
    pupil_diameter_m: f64,
) -> Result<crate::flare::PupilFlare> {
    let a_m = pupil_diameter_m / 2.0;
    let mut f = crate::flare::PupilFlare::new();
    if fc.dust_count.is_some() || fc.dust_coverage.is_some() {
        let [lo, hi] = fc.dust_radius_um;
        if !(lo > 0.0 && lo <= hi && hi.is_finite()) {
            return Err(OpticsError::config(
                "flare.dust_radius_um",
                format!("[{lo}, {hi}] um: give [min, max] with 0 < min <= max"),
            ));
        }
        if fc.dust_count.is_some() && fc.dust_coverage.is_some() {
            return Err(OpticsError::config(
                "flare.dust_count",
                "give one of dust_count or dust_coverage, not both",
            ));
        }
        f = f.with_dust(
            fc.seed,
            fc.dust_count,
            fc.dust_coverage,
            (lo * 1e-6 / a_m, hi * 1e-6 / a_m),
            1.0 - fc.dust_opacity,
        )?;
    }
    if fc.scratch_count > 0 {
        if !(fc.scratch_width_um > 0.0 && fc.scratch_width_um.is_finite()) {
            return Err(OpticsError::config(
                "flare.scratch_width_um",
                format!("{} um is not a positive width", fc.scratch_width_um),
            ));
        }
        let length_m = fc
            .scratch_length_mm
            .map(|l| l * 1e-3)
            .unwrap_or(pupil_diameter_m);
        f = f.with_scratches(
            fc.seed,
            fc.scratch_count,
            fc.scratch_width_um * 1e-6 / a_m,
            length_m / a_m,
            fc.scratch_angle_deg,
            1.0 - fc.scratch_opacity,
        )?;
    }
    if fc.smudge_rms_waves != 0.0 {
        let corr_m = fc
            .smudge_correlation_mm
            .map(|l| l * 1e-3)
            .unwrap_or(pupil_diameter_m / 10.0);
        f = f.with_smudge(fc.seed, fc.smudge_rms_waves, corr_m / a_m)?;
    }
    if let Some(p) = &fc.mask {
        f = f.with_mask(crate::aperture::TransmissionMask::from_file(p)?);
    }
    if let Some(p) = &fc.phase_mask {
        f = f.with_phase_mask(
            crate::aperture::TransmissionMask::from_file(p)?,
            fc.phase_mask_waves,
        )?;
    } else if fc.phase_mask_waves != 1.0 {
        return Err(OpticsError::config(
            "flare.phase_mask_waves",
            "given without a phase_mask",
        ));
    }
    Ok(f)
}
