//! The wavefront aberration model (as ISETCam's `wvf`): Zernike coefficients over a measurement
//! pupil, the lens pupil as aperture, the pupil function and its PSF by FFT.

use crate::aperture::Aperture;
use crate::error::{OpticsError, Result};
use crate::flare::PupilFlare;
use crate::lens;
use crate::psf::{MtfCurve, Psf};
use crate::zernike::Zernike;
use camsim_core::Spectrum;
use rayon::prelude::*;
use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::PI;
use std::sync::Arc;

/// Smallest FFT length >= n of the form 2^a 3^b 5^c (fast in rustfft), even.
pub fn fast_fft_len(n: usize) -> usize {
    let mut m = n.max(2);
    loop {
        let mut k = m;
        for p in [2, 3, 5] {
            while k.is_multiple_of(p) {
                k /= p;
            }
        }
        if k == 1 && m.is_multiple_of(2) {
            return m;
        }
        m += 1;
    }
}

/// Largest PSF FFT side we accept (a 8192^2 complex f64 array is 1 GiB).
pub const MAX_PSF_FFT: usize = 8192;

/// A lens described by its pupil and a Zernike wavefront aberration.
///
/// Conventions (ISETCam `wvf`): coefficients `zernike_um[j]` in micrometres of optical path,
/// OSA/ANSI index j, unit-RMS polynomials; W(rho, theta) is evaluated with rho normalized by the
/// *measurement* pupil radius, while the aperture is the *lens* pupil (diameter = focal length /
/// f-number), which must not be larger than the measurement pupil. The coefficients do not depend
/// on wavelength (they are optical path), except for the optional chromatic defocus curve.
/// The pupil function is `A(x, y) exp(-i 2 pi W / lambda)` (ISETCam `wvfComputePupilFunction`);
/// the pupil x axis runs along image columns, y along image rows.
#[derive(Debug, Clone)]
pub struct Wavefront {
    zernike_um: Vec<f64>,
    zern: Vec<Zernike>,
    measurement_pupil_m: f64,
    reference_wavelength_nm: f64,
    focal_length_m: f64,
    f_number: f64,
    image_distance_m: f64,
    extra_defocus_um: f64,
    chromatic_defocus_um: Option<Spectrum>,
    min_pupil_samples: usize,
    crosstalk_sigma_m: f64,
    /// FFT field of a trimmed kernel as a multiple of its side (None: 2.5, at most 2048 samples).
    kernel_field: Option<f64>,
    /// Pupil shape and transmission inside the lens pupil circle (default: the circle).
    aperture: Aperture,
    /// Contamination of the pupil (dust, scratches, smudges; [`crate::flare`]); None: clean.
    flare: Option<Arc<PupilFlare>>,
}

impl Wavefront {
    /// A diffraction-limited lens (all coefficients zero) focused at infinity.
    pub fn diffraction_limited(focal_length_m: f64, f_number: f64) -> Result<Self> {
        if !(focal_length_m > 0.0 && focal_length_m.is_finite()) {
            return Err(OpticsError::config(
                "focal_length_mm",
                format!("{} mm is not a positive number", focal_length_m * 1e3),
            ));
        }
        if !(f_number > 0.0 && f_number.is_finite()) {
            return Err(OpticsError::config(
                "f_number",
                format!("{f_number} is not a positive number"),
            ));
        }
        Ok(Wavefront {
            zernike_um: Vec::new(),
            zern: Vec::new(),
            measurement_pupil_m: focal_length_m / f_number,
            reference_wavelength_nm: 550.0,
            focal_length_m,
            f_number,
            image_distance_m: focal_length_m,
            extra_defocus_um: 0.0,
            chromatic_defocus_um: None,
            min_pupil_samples: 64,
            crosstalk_sigma_m: 0.0,
            kernel_field: None,
            aperture: Aperture::default(),
            flare: None,
        })
    }

    /// Set the Zernike coefficients (um, indexed by OSA j) and the measurement pupil diameter (m).
    pub fn with_zernike(mut self, zernike_um: Vec<f64>, measurement_pupil_m: f64) -> Result<Self> {
        if let Some((j, c)) = zernike_um.iter().enumerate().find(|(_, c)| !c.is_finite()) {
            return Err(OpticsError::config(
                format!("wavefront.zernike_um[{j}]"),
                format!("{c} is not a finite number"),
            ));
        }
        if zernike_um.len() > 231 {
            return Err(OpticsError::config(
                "wavefront.zernike_um",
                format!("{} terms; at most 231 (radial order 20)", zernike_um.len()),
            ));
        }
        if !(measurement_pupil_m > 0.0 && measurement_pupil_m.is_finite()) {
            return Err(OpticsError::config(
                "wavefront.measurement_pupil_mm",
                format!("{} mm is not a positive number", measurement_pupil_m * 1e3),
            ));
        }
        let lens = self.lens_pupil_diameter_m();
        if measurement_pupil_m < lens * (1.0 - 1e-9) {
            // ISETCam wvf refuses this too: the polynomials are only defined over the measured pupil.
            return Err(OpticsError::config(
                "wavefront.measurement_pupil_mm",
                format!(
                    "{:.4} mm is smaller than the lens pupil ({:.4} mm = focal length / f-number); the coefficients would be extrapolated",
                    measurement_pupil_m * 1e3,
                    lens * 1e3
                ),
            ));
        }
        self.zern = (0..zernike_um.len()).map(Zernike::new).collect();
        self.zernike_um = zernike_um;
        self.measurement_pupil_m = measurement_pupil_m;
        Ok(self)
    }

    /// Reference wavelength of the coefficients, nm (the chromatic defocus curve is taken relative
    /// to its value here).
    pub fn with_reference_wavelength(mut self, nm: f64) -> Result<Self> {
        if !(nm > 0.0 && nm.is_finite()) {
            return Err(OpticsError::config(
                "wavefront.reference_wavelength_nm",
                format!("{nm} is not a positive number"),
            ));
        }
        self.reference_wavelength_nm = nm;
        Ok(self)
    }

    /// Chromatic defocus: c4 (um, over the measurement pupil) against wavelength, added to j = 4
    /// after subtracting its value at the reference wavelength (like ISETCam's LCA model).
    pub fn with_chromatic_defocus(mut self, c4_um: Spectrum) -> Self {
        self.chromatic_defocus_um =
            Some(c4_um.with_extrapolation(camsim_core::spectrum::Extrapolation::Hold));
        self
    }

    /// Distance from the exit pupil to the sensor, m (default: the focal length, focus at
    /// infinity). Sets the PSF scale (lambda z / pupil sample) and the working f-number z / D.
    pub fn with_image_distance(mut self, image_distance_m: f64) -> Self {
        self.image_distance_m = image_distance_m;
        self
    }

    /// Add a defocus c4 (um) defined over the *lens* pupil (a focus error; see
    /// [`lens::defocus_c4_um`]).
    pub fn with_extra_defocus_um(mut self, c4_um: f64) -> Self {
        self.extra_defocus_um = c4_um;
        self
    }

    /// Minimum number of pupil samples across the lens pupil diameter in PSF computations (64).
    pub fn with_min_pupil_samples(mut self, n: usize) -> Self {
        self.min_pupil_samples = n.max(16);
        self
    }

    /// Convolve every PSF with a Gaussian of standard deviation `sigma_m` in the sensor plane:
    /// pixel crosstalk (carrier diffusion, optical crosstalk between photodiodes) as a
    /// shift-invariant blur, MTF factor exp(-2 pi^2 sigma^2 f^2) (see [`crate::mtf_fit`]). The
    /// stages are linear and shift-invariant, so applying the sensor's blur with the lens PSF gives
    /// the same image as applying it in the sensor. Negative or non-finite values count as 0.
    pub fn with_crosstalk_sigma_m(mut self, sigma_m: f64) -> Self {
        self.crosstalk_sigma_m = if sigma_m.is_finite() && sigma_m > 0.0 {
            sigma_m
        } else {
            0.0
        };
        self
    }

    /// FFT field of the kernels ([`Self::psf_with`]) as a multiple of the kernel side (>= 1.3):
    /// the FFT PSF is periodic, so the tail beyond the field folds back into the kernel. The
    /// default (2.5, up to 2048 samples) keeps that fold small enough for the far-tail model; the
    /// shift-variant blur, which renormalizes its trimmed kernels and adds no far tail, uses 1.3
    /// (about a quarter of the FFT work).
    pub fn with_kernel_field(mut self, factor: f64) -> Self {
        self.kernel_field = Some(factor.max(1.3));
        self
    }

    /// The pupil's shape (iris blades, obstruction, vanes, mask) inside the lens pupil circle,
    /// whose diameter focal length / f-number stays the circumscribed one (see
    /// [`crate::aperture`]). The PSF stays normalized to unit volume.
    pub fn with_aperture(mut self, aperture: Aperture) -> Self {
        self.aperture = aperture;
        self
    }

    /// The pupil's shape.
    pub fn aperture(&self) -> &Aperture {
        &self.aperture
    }

    /// Contaminate the pupil with dust, scratches, smudges or masks ([`crate::flare`]); an empty
    /// [`PupilFlare`] is the clean pupil (the PSF code then runs its original path, bit for bit).
    /// The PSF stays normalized to unit volume; [`Self::transmitted_fraction`] is its energy.
    pub fn with_flare(mut self, flare: PupilFlare) -> Self {
        self.flare = (!flare.is_empty()).then(|| Arc::new(flare));
        self
    }

    /// The pupil's contamination, if any.
    pub fn flare(&self) -> Option<&PupilFlare> {
        self.flare.as_deref()
    }

    /// Transmitted fraction of the pupil (shape, aperture mask and flare) relative to the clean
    /// circle: [`Aperture::area_fraction`] times the flare's energy transmission averaged over
    /// the open aperture (the integral of |P|^2 with and without the flare, on a 1024 x 1024 grid
    /// over the bounding square, 8 x 8 subsamples on every edge). 1 for the clean circle.
    pub fn transmitted_fraction(&self) -> f64 {
        let area = self.aperture.area_fraction();
        let Some(fl) = &self.flare else {
            return area;
        };
        let n = 1024usize;
        let cell = 2.0 / n as f64;
        let sums: Vec<(f64, f64)> = (0..n)
            .into_par_iter()
            .map(|i| {
                let y = -1.0 + (i as f64 + 0.5) * cell;
                let (mut open, mut passed) = (0.0, 0.0);
                for j in 0..n {
                    let x = -1.0 + (j as f64 + 0.5) * cell;
                    let (amp, e) = self.aperture.cell_amplitude(x, y, cell);
                    if amp > 0.0 {
                        open += e;
                        passed += e * fl.cell(x, y, cell).1;
                    }
                }
                (open, passed)
            })
            .collect();
        let (open, passed) = sums
            .iter()
            .fold((0.0, 0.0), |(o, p), (a, b)| (o + a, p + b));
        area * passed / open
    }

    /// Crosstalk Gaussian standard deviation, m (0: none).
    pub fn crosstalk_sigma_m(&self) -> f64 {
        self.crosstalk_sigma_m
    }

    /// Zernike coefficients, um, indexed by OSA j.
    pub fn zernike_um(&self) -> &[f64] {
        &self.zernike_um
    }
    /// Measurement pupil diameter, m.
    pub fn measurement_pupil_m(&self) -> f64 {
        self.measurement_pupil_m
    }
    /// Lens (entrance/exit) pupil diameter = focal length / f-number, m.
    pub fn lens_pupil_diameter_m(&self) -> f64 {
        self.focal_length_m / self.f_number
    }
    /// Focal length, m.
    pub fn focal_length_m(&self) -> f64 {
        self.focal_length_m
    }
    /// f-number (focal length / pupil diameter).
    pub fn f_number(&self) -> f64 {
        self.f_number
    }
    /// Exit pupil to sensor distance, m.
    pub fn image_distance_m(&self) -> f64 {
        self.image_distance_m
    }
    /// Working f-number: image distance / pupil diameter (sets the diffraction scale).
    pub fn working_f_number(&self) -> f64 {
        self.image_distance_m / self.lens_pupil_diameter_m()
    }
    /// Reference wavelength, nm.
    pub fn reference_wavelength_nm(&self) -> f64 {
        self.reference_wavelength_nm
    }
    /// Extra defocus over the lens pupil (focus error), um.
    pub fn extra_defocus_um(&self) -> f64 {
        self.extra_defocus_um
    }

    fn chromatic_c4_um(&self, wavelength_nm: f64) -> f64 {
        match &self.chromatic_defocus_um {
            Some(s) => s.eval(wavelength_nm) - s.eval(self.reference_wavelength_nm),
            None => 0.0,
        }
    }

    /// The defocus coefficient c4 (um) expressed over the lens pupil at the reference wavelength:
    /// c4_meas (r_lens / r_meas)^2 plus any focus error. For the pixel4a preset this is
    /// 1.225 um * (2.532 / 8)^2 = 0.1227 um.
    pub fn defocus_at_lens_pupil_um(&self) -> f64 {
        self.defocus_at_lens_pupil_um_at(self.reference_wavelength_nm)
    }

    /// As [`Self::defocus_at_lens_pupil_um`], including the chromatic defocus at `wavelength_nm`.
    pub fn defocus_at_lens_pupil_um_at(&self, wavelength_nm: f64) -> f64 {
        let c4 =
            self.zernike_um.get(4).copied().unwrap_or(0.0) + self.chromatic_c4_um(wavelength_nm);
        lens::rescale_defocus(
            c4,
            self.measurement_pupil_m / 2.0,
            self.lens_pupil_diameter_m() / 2.0,
        ) + self.extra_defocus_um
    }

    /// Wavefront aberration W in um at a point of the lens pupil given in lens-pupil-normalized
    /// coordinates (x, y), x^2 + y^2 <= 1.
    pub fn wavefront_um(&self, x: f64, y: f64, wavelength_nm: f64) -> f64 {
        let scale = self.lens_pupil_diameter_m() / self.measurement_pupil_m;
        let rho_l = (x * x + y * y).sqrt();
        let rho = rho_l * scale;
        // Powers and harmonics once per point for all terms (no trigonometry per term).
        let order = self.zern.last().map(|z| z.n).unwrap_or(0);
        let p = crate::zernike::PointTerms::new(rho, x, y, order);
        let mut w = 0.0;
        for (c, z) in self.zernike_um.iter().zip(&self.zern) {
            if *c != 0.0 {
                w += c * z.eval_at(&p);
            }
        }
        let sq3 = 3f64.sqrt();
        let chrom = self.chromatic_c4_um(wavelength_nm);
        if chrom != 0.0 {
            w += chrom * sq3 * (2.0 * rho * rho - 1.0);
        }
        if self.extra_defocus_um != 0.0 {
            w += self.extra_defocus_um * sq3 * (2.0 * rho_l * rho_l - 1.0);
        }
        w
    }

    /// True when every nonzero term is rotationally symmetric (m = 0): W depends on rho only.
    pub fn is_rotationally_symmetric(&self) -> bool {
        self.zernike_um
            .iter()
            .zip(&self.zern)
            .all(|(c, z)| *c == 0.0 || z.m == 0)
    }

    /// W (um) of a rotationally symmetric wavefront at lens-pupil radius `rho_l` (no trigonometry;
    /// equals [`Self::wavefront_um`] when [`Self::is_rotationally_symmetric`]).
    fn wavefront_radial_um(&self, rho_l: f64, chrom: f64) -> f64 {
        let rho = rho_l * self.lens_pupil_diameter_m() / self.measurement_pupil_m;
        let mut w = 0.0;
        for (c, z) in self.zernike_um.iter().zip(&self.zern) {
            if *c != 0.0 {
                w += c * z.eval(rho, 0.0);
            }
        }
        let sq3 = 3f64.sqrt();
        w + chrom * sq3 * (2.0 * rho * rho - 1.0)
            + self.extra_defocus_um * sq3 * (2.0 * rho_l * rho_l - 1.0)
    }

    /// Geometric blur radius, m: the largest transverse ray aberration over the pupil,
    /// |eps| = (z / a) |grad_rho W| (Welford, Aberrations of Optical Systems, eq. 7.3; z image
    /// distance, a pupil radius, rho normalized pupil coordinate). Tilt counts (it moves the PSF).
    pub fn geometric_blur_radius_m(&self, wavelength_nm: f64) -> f64 {
        let n = 24;
        let h = 1e-4;
        let mut g_max: f64 = 0.0;
        for i in 0..=n {
            for j in 0..=n {
                let x = -1.0 + 2.0 * i as f64 / n as f64;
                let y = -1.0 + 2.0 * j as f64 / n as f64;
                if x * x + y * y > 1.0 {
                    continue;
                }
                let gx = (self.wavefront_um(x + h, y, wavelength_nm)
                    - self.wavefront_um(x - h, y, wavelength_nm))
                    / (2.0 * h);
                let gy = (self.wavefront_um(x, y + h, wavelength_nm)
                    - self.wavefront_um(x, y - h, wavelength_nm))
                    / (2.0 * h);
                g_max = g_max.max((gx * gx + gy * gy).sqrt());
            }
        }
        let a = self.lens_pupil_diameter_m() / 2.0;
        self.image_distance_m / a * g_max * 1e-6
    }

    /// Kernel size (odd, samples) that holds the geometric blur plus the diffraction tail up to
    /// `tail_energy` (fraction of the energy left outside): for an Airy pattern the energy outside
    /// radius r tends to 2 lambda N / (pi^2 r) (Born & Wolf sec. 8.5.2, asymptote of 1 - J0^2 - J1^2).
    pub fn kernel_size(&self, wavelength_nm: f64, spacing_m: f64, tail_energy: f64) -> usize {
        let lam_n = wavelength_nm * 1e-9 * self.working_f_number();
        // A Gaussian crosstalk blur holds all but exp(-3.5^2 / 2) = 0.2 % of its energy within
        // 3.5 sigma (2-D).
        let r = self.geometric_blur_radius_m(wavelength_nm)
            + 2.0 * lam_n / (PI * PI * tail_energy.max(1e-6))
            + lam_n
            + 3.5 * self.crosstalk_sigma_m;
        2 * (r / spacing_m).ceil() as usize + 1
    }

    /// Oversampling factor (odd) used for a kernel at `spacing_m`: 1 when the image samples the
    /// optics at or above Nyquist (spacing <= lambda N / 2), else the smallest odd k with
    /// spacing / k <= lambda N / 2, at least `min_k`.
    pub fn oversampling(&self, wavelength_nm: f64, spacing_m: f64, min_k: usize) -> usize {
        let lam_n = wavelength_nm * 1e-9 * self.working_f_number();
        let mut k = (spacing_m / (0.5 * lam_n) * (1.0 - 1e-9)).ceil().max(1.0) as usize;
        k = k.max(min_k.max(1));
        if k.is_multiple_of(2) {
            k += 1;
        }
        k
    }

    /// The PSF that blurs an image sampled at `spacing_m`, as a `size` x `size` kernel (odd size),
    /// unit volume. When `spacing_m <= lambda N / 2` (the image samples the optics at Nyquist or
    /// finer) it is the PSF sampled at the image samples: the pupil plane spacing is chosen as
    /// dp = lambda z / (N_fft spacing), so the FFT's output spacing equals the image spacing. When
    /// the image is coarser, the PSF is computed at spacing / k (k odd, see [`Self::oversampling`])
    /// and summed over each k x k cell, i.e. integrated over the image sample cell (image values
    /// are cell averages); this is also what `min_oversampling > 1` asks for.
    pub fn psf(&self, wavelength_nm: f64, spacing_m: f64, size: usize) -> Result<Psf> {
        self.psf_with(wavelength_nm, spacing_m, size, 1)
    }

    /// [`Self::psf`] with a minimum oversampling factor.
    pub fn psf_with(
        &self,
        wavelength_nm: f64,
        spacing_m: f64,
        size: usize,
        min_oversampling: usize,
    ) -> Result<Psf> {
        if !(wavelength_nm > 0.0 && wavelength_nm.is_finite()) {
            return Err(OpticsError::Input(format!(
                "PSF wavelength {wavelength_nm} nm is not a positive number"
            )));
        }
        if !(spacing_m > 0.0 && spacing_m.is_finite()) {
            return Err(OpticsError::Input(format!(
                "PSF sample spacing {spacing_m} m is not a positive number"
            )));
        }
        if size == 0 || size.is_multiple_of(2) {
            return Err(OpticsError::Input(format!("PSF size {size} must be odd")));
        }
        let k = self.oversampling(wavelength_nm, spacing_m, min_oversampling);
        let fine = self.psf_grid(wavelength_nm, spacing_m / k as f64, Some(size * k), None)?;
        let mut data = vec![0.0; size * size];
        let nf = size * k;
        for r in 0..nf {
            for c in 0..nf {
                data[(r / k) * size + c / k] += fine[r * nf + c];
            }
        }
        let s: f64 = data.iter().sum();
        data.iter_mut().for_each(|v| *v /= s);
        Ok(Psf {
            wavelength_nm,
            spacing_m,
            size,
            data,
        })
    }

    /// The complete (periodized) PSF on an N x N grid at `spacing_m`, centre at (N/2, N/2), where
    /// N is the FFT size chosen for the pupil sampling; its discrete Fourier transform is exactly the
    /// OTF of the sampled pupil. `spacing_m` must be <= lambda N / 2.
    pub fn psf_full(&self, wavelength_nm: f64, spacing_m: f64) -> Result<Psf> {
        let lam_n = wavelength_nm * 1e-9 * self.working_f_number();
        if spacing_m > 0.5 * lam_n * (1.0 + 1e-9) {
            return Err(OpticsError::Input(format!(
                "full PSF spacing {spacing_m} m exceeds lambda N / 2 = {} m (the PSF would alias)",
                0.5 * lam_n
            )));
        }
        let data = self.psf_grid(wavelength_nm, spacing_m, None, None)?;
        let size = (data.len() as f64).sqrt().round() as usize;
        Ok(Psf {
            wavelength_nm,
            spacing_m,
            size,
            data,
        })
    }

    /// [`Self::psf_full`] and the PSF's energy before normalization, as a fraction of the clean
    /// circular pupil's (the sum of |DFT|^2 over the whole periodic grid, by Parseval the pupil's
    /// sampled integral of |P|^2, rim pedestal included).
    pub fn psf_full_energy(&self, wavelength_nm: f64, spacing_m: f64) -> Result<(Psf, f64)> {
        let lam_n = wavelength_nm * 1e-9 * self.working_f_number();
        if spacing_m > 0.5 * lam_n * (1.0 + 1e-9) {
            return Err(OpticsError::Input(format!(
                "full PSF spacing {spacing_m} m exceeds lambda N / 2 = {} m (the PSF would alias)",
                0.5 * lam_n
            )));
        }
        let (data, energy) = self.psf_grid_energy(wavelength_nm, spacing_m, None, None)?;
        let size = (data.len() as f64).sqrt().round() as usize;
        Ok((
            Psf {
                wavelength_nm,
                spacing_m,
                size,
                data,
            },
            energy,
        ))
    }

    /// The PSF periodized with period `rows` x `cols` samples at `spacing_m`, integrated over the
    /// sample cells like [`Self::psf_with`], with its centre at sample (0, 0) (row-major,
    /// `rows * cols`, unit sum). Its 2-D DFT is the OTF at the frequencies of a `rows` x `cols` image
    /// (k / (rows spacing), l / (cols spacing)): multiplying an image's spectrum by it is ISETCam's
    /// whole-image OTF blur (`opticsOTF`), a circular convolution with the untrimmed PSF. Computed on
    /// a square fine grid whose side is a multiple of k max(rows, cols) (k the oversampling), so
    /// the fold is exact along the longer side; along the shorter side only the tail beyond
    /// max(rows, cols) / 2 samples, already folded once, lands at a different (periodic) position.
    pub fn psf_periodic(
        &self,
        wavelength_nm: f64,
        spacing_m: f64,
        rows: usize,
        cols: usize,
        min_oversampling: usize,
    ) -> Result<Vec<f64>> {
        if !(wavelength_nm > 0.0 && wavelength_nm.is_finite()) {
            return Err(OpticsError::Input(format!(
                "PSF wavelength {wavelength_nm} nm is not a positive number"
            )));
        }
        if !(spacing_m > 0.0 && spacing_m.is_finite()) {
            return Err(OpticsError::Input(format!(
                "PSF sample spacing {spacing_m} m is not a positive number"
            )));
        }
        if rows == 0 || cols == 0 {
            return Err(OpticsError::Input(
                "periodic PSF needs at least one row and column".into(),
            ));
        }
        let k = self.oversampling(wavelength_nm, spacing_m, min_oversampling);
        let m = rows.max(cols);
        if m * k > MAX_PSF_FFT {
            return Err(OpticsError::Input(format!(
                "the periodic PSF for a {rows} x {cols} plane at {wavelength_nm} nm needs a {n} x {n} grid ({k}x oversampled; at most \
                 {MAX_PSF_FFT}): the whole-image OTF (psf.method = \"otf\") is for small images; use \"auto\" or \"kernel\"",
                n = m * k
            )));
        }
        let fine = self.psf_grid(wavelength_nm, spacing_m / k as f64, None, Some(m * k))?;
        let nf = (fine.len() as f64).sqrt().round() as usize;
        let half = (nf / 2) as i64;
        let kh = (k / 2) as i64;
        // Fine sample i lies at offset i - N/2 from the axis; cell c (odd k) holds the offsets
        // c k - k/2 ..= c k + k/2.
        let cell = |i: usize| (i as i64 - half + kh).div_euclid(k as i64);
        let rix: Vec<usize> = (0..nf)
            .map(|i| cell(i).rem_euclid(rows as i64) as usize)
            .collect();
        let cix: Vec<usize> = (0..nf)
            .map(|i| cell(i).rem_euclid(cols as i64) as usize)
            .collect();
        let mut data = vec![0.0; rows * cols];
        for (r, ri) in rix.iter().enumerate() {
            let dst = &mut data[ri * cols..(ri + 1) * cols];
            for (v, ci) in fine[r * nf..(r + 1) * nf].iter().zip(&cix) {
                dst[*ci] += v;
            }
        }
        let s: f64 = data.iter().sum();
        data.iter_mut().for_each(|v| *v /= s);
        Ok(data)
    }

    /// Radial MTF curves (x and y) at `wavelength_nm` from 0 to the diffraction cutoff 1/(lambda N),
    /// in cycles/mm in the sensor plane, from the full PSF at spacing lambda N / 4 (128 pupil
    /// samples across the pupil at least; frequency step = cutoff / (pupil samples)).
    pub fn mtf(&self, wavelength_nm: f64) -> Result<MtfCurve> {
        let lam_n = wavelength_nm * 1e-9 * self.working_f_number();
        let psf = self
            .clone()
            .with_min_pupil_samples(self.min_pupil_samples.max(128))
            .psf_full(wavelength_nm, lam_n / 4.0)?;
        let mut m = psf.mtf();
        let cutoff = 1e-3 / lam_n;
        let keep = m
            .freq_cyc_per_mm
            .iter()
            .take_while(|f| **f <= cutoff * (1.0 + 1e-9))
            .count();
        m.freq_cyc_per_mm.truncate(keep);
        m.mtf_x.truncate(keep);
        m.mtf_y.truncate(keep);
        Ok(m)
    }

    /// Core PSF computation at spacing `dx` (<= lambda N / 2). Returns `n_out x n_out` samples
    /// centred on the middle one, or the full N x N grid (centre N/2) for `None`; unit sum.
    /// With `period = Some(p)` the FFT side N is a multiple of p (so the periodized PSF, folded
    /// modulo p, is the PSF periodized with period p samples exactly).
    fn psf_grid(
        &self,
        wavelength_nm: f64,
        dx: f64,
        n_out: Option<usize>,
        period: Option<usize>,
    ) -> Result<Vec<f64>> {
        Ok(self.psf_grid_energy(wavelength_nm, dx, n_out, period)?.0)
    }

    /// [`Self::psf_grid`] and the sum of its samples before normalization divided by the clean
    /// circle's (N^2 pi a^2 / dp^2: Parseval's theorem for the N x N DFT of a unit pupil).
    fn psf_grid_energy(
        &self,
        wavelength_nm: f64,
        dx: f64,
        n_out: Option<usize>,
        period: Option<usize>,
    ) -> Result<(Vec<f64>, f64)> {
        let lambda_m = wavelength_nm * 1e-9;
        let z = self.image_distance_m;
        let d = self.lens_pupil_diameter_m();
        let a = d / 2.0;
        // Pupil diameter in pupil samples per FFT sample: n_p = q N (PSF spacing = lambda z / (N dp)).
        let q = dx * d / (lambda_m * z);
        let blur = self.geometric_blur_radius_m(wavelength_nm) + 2.0 * self.crosstalk_sigma_m;
        let want = [
            // The FFT's PSF is periodic: the tail beyond the field folds back into it, and the rim
            // pedestal spreads over the field. With the old 1.3x field the window held so much of
            // both that adding the far tail (crate::tail) double-counted it (dark chart patches
            // +1.2 %). A field 2.5x the window (at most 2048 samples, at least 1.3x) leaves a small
            // fold near the rim: chart patch means within 0.05 % of the whole-image OTF (0.10 %
            // at 4x, whose cleaner window is short of the asymptote's slight underestimate of the
            // near tail), and a third of 4x's cost per PSF.
            n_out
                .map(|n| match self.kernel_field {
                    Some(f) => (f * n as f64).ceil(),
                    None => (2.5 * n as f64).min(2048.0).max(1.3 * n as f64).ceil(),
                })
                .unwrap_or(0.0),
            self.min_pupil_samples as f64 / q,
            // The field must hold the geometric blur with room for the diffraction tail; this also
            // samples the pupil phase finely enough (the phase steps by < pi per pupil sample).
            (3.0 * blur + 16.0 * lambda_m * z / d) / dx,
            32.0,
            // A contaminated pupil: at least 4 pupil samples across its smallest feature (dust
            // diameter, scratch width; up to 1024 across the pupil), so the field holds the
            // feature's diffraction out to lambda z / (2 feature) (what lies beyond folds back).
            match self.flare.as_ref().map(|f| f.min_feature()) {
                Some(m) if m > 0.0 => (8.0 / m).min(1024.0) / q,
                _ => 0.0,
            },
        ];
        let need = want.iter().cloned().fold(0.0, f64::max).ceil() as usize;
        let n = match period {
            Some(p) => need.div_ceil(p).max(1) * p,
            None => fast_fft_len(need),
        };
        if n > MAX_PSF_FFT {
            return Err(OpticsError::Input(format!(
                "the PSF at {wavelength_nm} nm and spacing {:.3} um needs a {n} x {n} FFT (more than {MAX_PSF_FFT}); \
                 the aberration blurs over {:.1} um: use a coarser image spacing or a smaller aberration",
                dx * 1e6,
                blur * 2e6
            )));
        }
        camsim_core::mem::check_alloc((n * n * 16) as u64, "the PSF pupil array")?;
        let dp = lambda_m * z / (n as f64 * dx);
        let half = n / 2;
        let rp = (a / dp).ceil() as usize + 1;
        let lo = half.saturating_sub(rp);
        let hi = (half + rp).min(n - 1);
        let mut planner = FftPlanner::<f64>::new();
        let fft = planner.plan_fft_forward(n);
        let mut scratch = vec![Complex64::new(0.0, 0.0); fft.get_inplace_scratch_len()];
        // Pupil rows (only those that intersect the aperture), transformed along x.
        let nrows = hi - lo + 1;
        let mut rows = vec![Complex64::new(0.0, 0.0); nrows * n];
        let sub = 8usize;
        let inv_lambda_um = 1e3 / wavelength_nm; // W in um -> waves
        let (mut sum_cov, mut sum_cov2) = (0.0f64, 0.0f64);
        let symmetric = self.is_rotationally_symmetric();
        let circle = self.aperture.is_circle() && self.flare.is_none();
        let chrom = self.chromatic_c4_um(wavelength_nm);
        for (ri, i) in (lo..=hi).enumerate() {
            let y = (i as f64 - half as f64) * dp;
            let row = &mut rows[ri * n..(ri + 1) * n];
            for j in lo..=hi {
                let x = (j as f64 - half as f64) * dp;
                let r = (x * x + y * y).sqrt();
                // Aperture amplitude: fraction of the sample cell inside the pupil (8 x 8 subsamples
                // on the rim), so the discrete pupil has the right area and shape.
                // A shaped aperture (crate::aperture) gives the amplitude and the energy it
                // passes (they differ with a grey mask); the circle keeps its original code.
                let mut energy = None;
                let mut flare_waves = 0.0;
                let cov = if !circle {
                    let (mut amp, mut e) = self.aperture.cell_amplitude(x / a, y / a, dp / a);
                    if let (Some(f), true) = (&self.flare, amp > 0.0) {
                        // Contamination (crate::flare): its amplitude and energy transmission
                        // multiply the aperture's; its phase adds to the wavefront's.
                        let (fa, fe, ph) = f.cell(x / a, y / a, dp / a);
                        amp *= fa;
                        e *= fe;
                        flare_waves = ph;
                    }
                    energy = Some(e);
                    amp
                } else if r + 0.7072 * dp <= a {
                    1.0
                } else if r - 0.7072 * dp > a {
                    0.0
                } else {
                    let mut c = 0usize;
                    for sy in 0..sub {
                        for sx in 0..sub {
                            let xx = x + ((sx as f64 + 0.5) / sub as f64 - 0.5) * dp;
                            let yy = y + ((sy as f64 + 0.5) / sub as f64 - 0.5) * dp;
                            if xx * xx + yy * yy <= a * a {
                                c += 1;
                            }
                        }
                    }
                    c as f64 / (sub * sub) as f64
                };
                if cov > 0.0 {
                    sum_cov += energy.unwrap_or(cov);
                    sum_cov2 += cov * cov;
                    let w_um = if symmetric {
                        self.wavefront_radial_um((r / a).min(1.0), chrom)
                    } else {
                        let (xn, yn) = ((x / a).clamp(-1.0, 1.0), (y / a).clamp(-1.0, 1.0));
                        self.wavefront_um(xn, yn, wavelength_nm)
                    };
                    // Pupil function A exp(-i 2 pi W / lambda) (ISETCam wvfComputePupilFunction).
                    let ph = if flare_waves == 0.0 {
                        -2.0 * PI * w_um * inv_lambda_um
                    } else {
                        -2.0 * PI * (w_um * inv_lambda_um + flare_waves)
                    };
                    let (s_ph, c_ph) = ph.sin_cos();
                    row[j] = Complex64::new(cov * c_ph, cov * s_ph);
                }
            }
            fft.process_with_scratch(row, &mut scratch);
        }
        // Columns: only those we return.
        let (m, kxs): (usize, Vec<usize>) = match n_out {
            Some(no) => {
                let h = (no / 2) as i64;
                (
                    no,
                    (-h..=h).map(|k| k.rem_euclid(n as i64) as usize).collect(),
                )
            }
            None => (n, (0..n).map(|p| (p + n - half) % n).collect()),
        };
        let kys = kxs.clone();
        // Rim cells carry amplitude = covered fraction c. Then the discrete autocorrelation of the
        // pupil matches the continuous one at every nonzero lag, but its zero lag is sum c^2 instead
        // of the area sum c. Restore the zero lag by a constant (white) pedestal of
        // (sum c - sum c^2) per PSF sample (the DFT of a constant is a delta at zero frequency).
        // With a grey mask of transmission t the amplitude is c t and the zero lag should be
        // sum c t^2 (the pupil's |A|^2 integral): sum_cov then holds c t^2.
        let pedestal = sum_cov - sum_cov2;
        let mut out = vec![0.0f64; m * m];
        let mut col = vec![Complex64::new(0.0, 0.0); n];
        for (ox, &kx) in kxs.iter().enumerate() {
            col.iter_mut().for_each(|c| *c = Complex64::new(0.0, 0.0));
            for ri in 0..nrows {
                col[lo + ri] = rows[ri * n + kx];
            }
            fft.process_with_scratch(&mut col, &mut scratch);
            for (oy, &ky) in kys.iter().enumerate() {
                out[oy * m + ox] = col[ky].norm_sqr() + pedestal;
            }
        }
        if self.crosstalk_sigma_m > 0.0 {
            // The full grid (n_out None) is one period of the periodic PSF: convolve circularly.
            gaussian_blur(&mut out, m, self.crosstalk_sigma_m / dx, n_out.is_none());
        }
        let s: f64 = out.iter().sum();
        if !(s > 0.0) {
            return Err(OpticsError::Input(format!(
                "PSF at {wavelength_nm} nm has no energy (pupil too small for the sampling)"
            )));
        }
        out.iter_mut().for_each(|v| *v /= s);
        // Parseval: the clean circle's sum is N^2 (pi a^2 / dp^2) (before any cropping to n_out).
        let energy = s / ((n * n) as f64 * PI * a * a / (dp * dp));
        Ok((out, energy))
    }
}

/// Separable convolution of the `m` x `m` row-major image `data` with a unit-sum Gaussian of
/// standard deviation `sigma_px` samples (sampled at the sample centres and normalized; the PSF
/// grid's spacing is at most lambda N / 2, well below a crosstalk sigma of a micrometre), cut at
/// 5 sigma; `periodic` wraps around the edges, otherwise light past an edge is lost.
fn gaussian_blur(data: &mut [f64], m: usize, sigma_px: f64, periodic: bool) {
    let half = (5.0 * sigma_px).ceil().max(1.0) as i64;
    let w: Vec<f64> = (-half..=half)
        .map(|k| (-0.5 * (k as f64 / sigma_px).powi(2)).exp())
        .collect();
    let ws: f64 = w.iter().sum();
    let w: Vec<f64> = w.iter().map(|v| v / ws).collect();
    let mut line = vec![0.0; m];
    let conv = |get: &mut dyn FnMut(usize) -> f64, line: &mut [f64]| {
        let src: Vec<f64> = (0..m).map(&mut *get).collect();
        for (i, out) in line.iter_mut().enumerate() {
            let mut acc = 0.0;
            for (k, wk) in w.iter().enumerate() {
                let j = i as i64 + k as i64 - half;
                let j = if periodic {
                    j.rem_euclid(m as i64)
                } else if j < 0 || j >= m as i64 {
                    continue;
                } else {
                    j
                };
                acc += wk * src[j as usize];
            }
            *out = acc;
        }
    };
    for r in 0..m {
        conv(&mut |c| data[r * m + c], &mut line);
        data[r * m..(r + 1) * m].copy_from_slice(&line);
    }
    for c in 0..m {
        conv(&mut |r| data[r * m + c], &mut line);
        for (r, v) in line.iter().enumerate() {
            data[r * m + c] = *v;
        }
    }
}
