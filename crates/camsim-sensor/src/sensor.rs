//! A validated sensor in SI units, its spectral QE and the analytic mean-signal and noise model.

use crate::config::{NoiseSwitches, SensorConfig};
use crate::error::{Result, SensorError};
use crate::presets;
use camsim_core::units::{PLANCK_J_S, SPEED_OF_LIGHT_M_PER_S};
use camsim_core::{CfaLayout, CfaPattern, Spectrum, WavelengthGrid};
use std::path::Path;

/// A sensor ready to compute: the config it came from plus every parameter in SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    config: SensorConfig,
    pub(crate) cfa: CfaPattern,
    /// A non-Bayer CFA (RGBW, Quad Bayer, `cfa_pattern`); `None` for the Bayer `cfa`.
    pub(crate) layout: Option<CfaLayout>,
    /// With `layout`: the effective QE of each of its filters, in its filter order.
    pub(crate) filter_qe: Vec<Spectrum>,
    pub(crate) pixel_pitch_m: f64,
    pub(crate) fill_factor: f64,
    pub(crate) conversion_gain_v_per_e: f64,
    pub(crate) voltage_swing_v: f64,
    pub(crate) analog_gain: f64,
    pub(crate) analog_offset_v: f64,
    /// Digital black-level pedestal, DN (`black_level_dn` of the config).
    pub(crate) black_level_pedestal_dn: f64,
    pub(crate) bits: u32,
    pub(crate) dsnu_v: f64,
    pub(crate) prnu_fraction: f64,
    pub(crate) dark_voltage_v_per_s: f64,
    pub(crate) read_noise_v: f64,
    pub(crate) noise: NoiseSwitches,
    /// Effective channel QE (filter x IR x pixel, then the correction), r, g, b.
    qe: [Spectrum; 3],
    /// `[defects]` drawn for this size ([`crate::defects`]).
    pub(crate) defects: Option<std::sync::Arc<crate::defects::DefectMap>>,
    /// One photodiode of a dual-pixel sensor ([`Sensor::dual_pixel_photodiodes`]): its well, as
    /// the largest pixel voltage it holds, V (`None`: the swing clips, as for any pixel).
    pub(crate) photodiode_clip_v: Option<f64>,
    /// Mixed into the frame key of the fixed-pattern and temporal streams (0: the pixel's own;
    /// the right photodiode of a dual pixel: [`RIGHT_PHOTODIODE_STREAM`]).
    pub(crate) stream_tag: u64,
}

/// The stream tag of a dual pixel's right photodiode: its fixed pattern and temporal noise are
/// streams of their own, independent of the left one's (which are the plain sensor's).
pub const RIGHT_PHOTODIODE_STREAM: u64 = 1 << 63;

/// Standard deviations of each noise source in DN for one pixel at a given mean signal, and
/// their quadrature sum (EMVA 1288 rel. 4.0 linear model, ISETCam noise sources).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseBreakdown {
    /// Photon shot noise, K sqrt(mu_photo_e), DN (temporal).
    pub shot: f64,
    /// Read noise, read_v x dn_per_v / gain, DN (temporal).
    pub read: f64,
    /// DSNU, dsnu_v x dn_per_v / gain, DN (spatial, fixed).
    pub dsnu: f64,
    /// PRNU, prnu x mean signal, DN (spatial, fixed).
    pub prnu: f64,
    /// Dark-current shot noise, K sqrt(mu_dark_e), DN (temporal).
    pub dark: f64,
    /// Quantization noise, 1/sqrt(12) DN (0 with quantization off).
    pub quantization: f64,
    /// sqrt of the sum of the squares, DN: the spread over pixels of one frame of a uniform field.
    pub total: f64,
}

impl NoiseBreakdown {
    /// Temporal part only (shot, dark shot, read, quantization): the spread of one pixel over frames, DN.
    pub fn temporal(&self) -> f64 {
        (self.shot.powi(2) + self.dark.powi(2) + self.read.powi(2) + self.quantization.powi(2))
            .sqrt()
    }
}

impl Sensor {
    /// Validate a config and convert it to SI units.
    pub fn from_config(config: SensorConfig) -> Result<Sensor> {
        Sensor::from_config_named(config, "sensor config")
    }

    /// As [`Sensor::from_config`], naming `source_name` (file or preset) in errors.
    /// A `[qe] file` still in the config is read relative to the current folder (see
    /// [`Sensor::from_file`] for files relative to the sensor TOML).
    pub fn from_config_named(mut config: SensorConfig, source_name: &str) -> Result<Sensor> {
        config.resolve(Path::new(""), source_name)?;
        config.validate(source_name)?;
        if let Some(b) = config.binning {
            // A binned sensor is the sensor of its output pixels ([`crate::binning`]).
            let binned = crate::binning::apply(&b, &config).map_err(|(key, message)| {
                SensorError::Config {
                    source_name: source_name.to_string(),
                    key,
                    message,
                }
            })?;
            return Sensor::from_config_named(binned, source_name);
        }
        let q = &config.qe;
        let n = q.wavelengths_nm.len();
        let ir = |k: usize| q.ir_cut.as_ref().map_or(1.0, |v| v[k]);
        let px = |k: usize| q.pixel_qe.as_ref().map_or(1.0, |v| v[k]);
        // ISETCam: spectral QE = colour filter x IR filter x photodetector QE.
        let raw: Vec<[f64; 3]> = (0..n)
            .map(|k| {
                let t = ir(k) * px(k);
                // r, g, b may be empty for a CFA without them (validated): QE 0 there.
                let at = |c: &[f64]| c.get(k).copied().unwrap_or(0.0);
                [at(&q.r) * t, at(&q.g) * t, at(&q.b) * t]
            })
            .collect();
        // The paper's eq. 1: [r', g', b'] = [r, g, b] M (rows of M index the input channel).
        let corrected: Vec<[f64; 3]> = match &config.qe_correction {
            None => raw,
            Some(m) => raw
                .iter()
                .map(|v| {
                    let mut o = [0.0; 3];
                    for (c, oc) in o.iter_mut().enumerate() {
                        *oc = (0..3).map(|i| v[i] * m[i][c]).sum();
                    }
                    o
                })
                .collect(),
        };
        let mk = |c: usize| -> Result<Spectrum> {
            Spectrum::new(
                q.wavelengths_nm.clone(),
                corrected.iter().map(|v| v[c]).collect(),
                "qe",
            )
            .map_err(SensorError::from)
        };
        let qe = [mk(0)?, mk(1)?, mk(2)?];
        let full_layout = config.cfa_layout()?;
        let (cfa, layout) = match full_layout.as_bayer() {
            Some(p) => (p, None),
            None => (CfaPattern::Rggb, Some(full_layout)),
        };
        // Filter QE of a general CFA: r, g, b as above (corrected); any other filter's
        // transmittance x IR cut x pixel QE (ISETCam spectral QE), `w` without a curve = 1.
        let mut filter_qe = Vec::new();
        for f in layout.iter().flat_map(|l| l.filters()) {
            let spectrum = match f.as_str() {
                "r" => qe[0].clone(),
                "g" => qe[1].clone(),
                "b" => qe[2].clone(),
                _ => {
                    let t = config.filter_curve(f);
                    let values = (0..n)
                        .map(|k| t.map_or(1.0, |t| t[k]) * ir(k) * px(k))
                        .collect();
                    Spectrum::new(q.wavelengths_nm.clone(), values, "qe")
                        .map_err(SensorError::from)?
                }
            };
            filter_qe.push(spectrum);
        }
        let defects = match &config.defects {
            Some(d) => Some(std::sync::Arc::new(d.draw(
                config.rows,
                config.cols,
                config.fixed_pattern_seed,
                ((1u64 << config.bits) - 1) as f64,
            )?)),
            None => None,
        };
        Ok(Sensor {
            defects,
            cfa,
            layout,
            filter_qe,
            pixel_pitch_m: config.pixel_pitch_um * 1e-6,
            fill_factor: config.fill_factor,
            conversion_gain_v_per_e: config.conversion_gain_uv_per_e * 1e-6,
            voltage_swing_v: config.voltage_swing_v,
            analog_gain: config.effective_analog_gain(),
            black_level_pedestal_dn: config.black_level_dn,
            analog_offset_v: config.analog_offset_mv * 1e-3,
            bits: config.bits,
            dsnu_v: config.dsnu_mv * 1e-3,
            prnu_fraction: config.prnu_percent * 1e-2,
            dark_voltage_v_per_s: config.dark_voltage_mv_per_s * 1e-3,
            read_noise_v: config.read_noise_mv * 1e-3,
            noise: config.noise,
            qe,
            config,
            photodiode_clip_v: None,
            stream_tag: 0,
        })
    }

    /// True for a dual-pixel sensor ([`SensorConfig::dual_pixel`]).
    pub fn is_dual_pixel(&self) -> bool {
        self.config.dual_pixel
    }

    /// The left and right photodiodes of a dual-pixel sensor, each as a sensor of its own that
    /// captures the irradiance through its half of the pupil: half the pixel's well (its
    /// voltage clips at half the swing: well = swing / conversion gain, ISETCam's), half its
    /// dark current (it has half the area), the same conversion gain, read noise, ADC and
    /// defect map, and a fixed pattern and temporal noise of its own (the left one's are the
    /// plain sensor's streams). Their raws sum to the pixel's ([`dual_pixel_sum`]).
    pub fn dual_pixel_photodiodes(&self) -> Result<[Sensor; 2]> {
        let mut c = self.config.clone();
        c.dual_pixel = false;
        c.dark_voltage_mv_per_s *= 0.5;
        // The cross-check of the pixel's well no longer applies to a photodiode.
        c.well_capacity_e = None;
        let mut left = Sensor::from_config_named(c, &self.config.name)?;
        left.photodiode_clip_v = Some(0.5 * self.voltage_swing_v);
        let mut right = left.clone();
        right.stream_tag = RIGHT_PHOTODIODE_STREAM;
        Ok([left, right])
    }

    /// Parse and validate TOML text; `source_name` names it in errors.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Sensor> {
        let config = SensorConfig::from_toml_str(text, source_name)?;
        Sensor::from_config_named(config, source_name)
    }

    /// Parse TOML text whose relative paths (`[qe] file`) are relative to `base_dir`.
    pub fn from_toml_str_in(text: &str, source_name: &str, base_dir: &Path) -> Result<Sensor> {
        let mut config = SensorConfig::from_toml_str(text, source_name)?;
        config.resolve(base_dir, source_name)?;
        Sensor::from_config_named(config, source_name)
    }

    /// Read a sensor TOML file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Sensor> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| camsim_core::CoreError::Io {
            path: path.to_path_buf(),
            source: e,
        })?;
        Sensor::from_toml_str_in(
            &text,
            &path.display().to_string(),
            path.parent().unwrap_or(Path::new("")),
        )
    }

    /// A built-in preset (`imx363`, `pixel4a`, `pixel4a-raw10`, `ideal`).
    pub fn preset(name: &str) -> Result<Sensor> {
        let text = presets::toml(name)?;
        Sensor::from_toml_str(text, &format!("preset {name}"))
    }

    /// The config this sensor was built from.
    pub fn config(&self) -> &SensorConfig {
        &self.config
    }

    /// The config as TOML text (parses back to the same sensor).
    pub fn to_toml(&self) -> String {
        self.config.to_toml()
    }

    /// The same sensor with another size (the fixed pattern of the top-left window is unchanged:
    /// it is keyed on row and column).
    pub fn with_size(&self, rows: usize, cols: usize) -> Result<Sensor> {
        let mut c = self.config.clone();
        c.rows = rows;
        c.cols = cols;
        Sensor::from_config_named(c, &self.config.name)
    }

    /// A window of `rows` x `cols` pixels of this sensor (e.g. `[sensor] rows/cols` of a simulate
    /// config, `camsim sensor --rows/--cols`). Unlike [`Sensor::with_size`] it refuses a window
    /// larger than the sensor: a 5000 x 6000 window of a 3024 x 4032 sensor does not exist.
    pub fn window(&self, rows: usize, cols: usize) -> Result<Sensor> {
        for (key, want, have) in [("rows", rows, self.rows()), ("cols", cols, self.cols())] {
            if want == 0 || want > have {
                return Err(SensorError::Config {
                    source_name: format!("window of sensor {}", self.config.name),
                    key: key.to_string(),
                    message: format!(
                        "{rows} x {cols} pixels does not fit the sensor, which is {} x {} pixels (rows x cols); {key} must be 1..={have}",
                        self.rows(),
                        self.cols()
                    ),
                });
            }
        }
        self.with_size(rows, cols)
    }

    /// The sensor's faulty pixels (`[defects]`), sorted by row then column; empty without.
    pub fn defect_list(&self) -> &[crate::defects::Defect] {
        self.defects
            .as_deref()
            .map_or(&[], |d| d.defects.as_slice())
    }

    /// The same sensor with other noise switches.
    pub fn with_noise(&self, noise: NoiseSwitches) -> Sensor {
        let mut s = self.clone();
        s.noise = noise;
        s.config.noise = noise;
        s
    }

    /// Name from the config.
    pub fn name(&self) -> &str {
        &self.config.name
    }
    /// Pixel rows.
    pub fn rows(&self) -> usize {
        self.config.rows
    }
    /// Pixel columns.
    pub fn cols(&self) -> usize {
        self.config.cols
    }
    /// Bayer pattern (RGGB, unused, for a non-Bayer CFA: see [`Sensor::cfa_layout`]).
    pub fn cfa(&self) -> CfaPattern {
        self.cfa
    }
    /// The colour filter array as a general layout (a Bayer pattern too).
    pub fn cfa_layout(&self) -> CfaLayout {
        self.layout
            .clone()
            .unwrap_or_else(|| CfaLayout::from_bayer(self.cfa))
    }
    /// True when the CFA is not a Bayer pattern (RGBW, Quad Bayer, `cfa_pattern`).
    pub fn is_bayer(&self) -> bool {
        self.layout.is_none()
    }
    /// Effective QE of each filter of [`Sensor::cfa_layout`], in its filter order.
    pub fn filter_qe_spectra(&self) -> Vec<&Spectrum> {
        if self.layout.is_some() {
            self.filter_qe.iter().collect()
        } else {
            self.qe.iter().collect()
        }
    }
    /// Pixel pitch, m.
    pub fn pixel_pitch_m(&self) -> f64 {
        self.pixel_pitch_m
    }
    /// Fill factor (fraction of the pixel area that is photosensitive).
    pub fn fill_factor(&self) -> f64 {
        self.fill_factor
    }
    /// Photosensitive area of one pixel, m^2 (pitch^2 x fill factor).
    pub fn photodetector_area_m2(&self) -> f64 {
        self.pixel_pitch_m * self.pixel_pitch_m * self.fill_factor
    }
    /// ADC bits.
    pub fn bits(&self) -> u32 {
        self.bits
    }
    /// Conversion gain, V per electron.
    pub fn conversion_gain_v_per_e(&self) -> f64 {
        self.conversion_gain_v_per_e
    }
    /// Voltage swing, V.
    pub fn voltage_swing_v(&self) -> f64 {
        self.voltage_swing_v
    }
    /// Analog gain, ISETCam's divisor (v_out = (v + offset) / gain); base_iso / iso when the
    /// config gives `iso`.
    pub fn analog_gain(&self) -> f64 {
        self.analog_gain
    }
    /// Analog offset, V.
    pub fn analog_offset_v(&self) -> f64 {
        self.analog_offset_v
    }
    /// Read noise sigma, V (at the pixel, before the analog gain).
    pub fn read_noise_v(&self) -> f64 {
        self.read_noise_v
    }
    /// DSNU sigma, V (at the pixel, before the analog gain).
    pub fn dsnu_v(&self) -> f64 {
        self.dsnu_v
    }
    /// PRNU sigma as a fraction of the signal.
    pub fn prnu_fraction(&self) -> f64 {
        self.prnu_fraction
    }
    /// Dark voltage rate, V/s.
    pub fn dark_voltage_v_per_s(&self) -> f64 {
        self.dark_voltage_v_per_s
    }
    /// Noise switches.
    pub fn noise(&self) -> NoiseSwitches {
        self.noise
    }

    /// Well capacity, electrons = voltage swing / conversion gain (ISETCam `pixelGet(...,'well capacity')`).
    pub fn well_capacity_e(&self) -> f64 {
        self.voltage_swing_v / self.conversion_gain_v_per_e
    }

    /// ADC scale, DN per volt at the ADC input = 2^bits / swing (quantization step swing / 2^bits).
    pub fn dn_per_v(&self) -> f64 {
        (1u64 << self.bits) as f64 / self.voltage_swing_v
    }

    /// Largest DN, 2^bits - 1.
    pub fn max_dn(&self) -> u32 {
        ((1u64 << self.bits) - 1) as u32
    }

    /// System gain K, DN per electron = conversion gain / analog gain x dn_per_v (EMVA 1288 K).
    pub fn k_dn_per_e(&self) -> f64 {
        self.conversion_gain_v_per_e / self.analog_gain * self.dn_per_v()
    }

    /// DN of zero light (noise-free, unrounded): offset / gain x dn_per_v + the black-level
    /// pedestal `black_level_dn` of the config.
    pub fn black_level_dn(&self) -> f64 {
        self.analog_offset_v / self.analog_gain * self.dn_per_v() + self.black_level_pedestal_dn
    }

    /// The digital black-level pedestal alone (`black_level_dn` of the config), DN.
    pub fn black_level_pedestal_dn(&self) -> f64 {
        self.black_level_pedestal_dn
    }

    /// ISO of this sensor: `iso` of the config, or base_iso / analog_gain when only `base_iso`
    /// is given; `None` without a base ISO.
    pub fn iso(&self) -> Option<f64> {
        self.config
            .iso
            .or_else(|| self.config.base_iso.map(|b| b / self.analog_gain))
    }

    /// Mean dark-current electrons in `exposure_s` (0 when the dark switch is off).
    pub fn dark_electrons(&self, exposure_s: f64) -> f64 {
        if self.noise.dark {
            self.dark_voltage_v_per_s * exposure_s / self.conversion_gain_v_per_e
        } else {
            0.0
        }
    }

    /// Effective QE of channel `c` (0 r, 1 g, 2 b) as a spectrum on the config's wavelengths.
    pub fn qe_spectrum(&self, c: usize) -> &Spectrum {
        &self.qe[c]
    }

    /// Effective channel QE (colour filter x IR-cut x pixel QE, corrected) resampled linearly to `grid`
    /// (0 outside the config's wavelengths), r, g, b.
    pub fn channel_qe(&self, grid: &WavelengthGrid) -> [Vec<f64>; 3] {
        [
            self.qe[0].sample(grid),
            self.qe[1].sample(grid),
            self.qe[2].sample(grid),
        ]
    }

    /// Electrons per second per pixel of each channel per unit spectral irradiance in each band:
    /// QE_c(lambda) x lambda / (h c) x d lambda x photodetector area (ISETCam sensorCompute:
    /// signal current density from irradiance, `Energy2Quanta`). Unit: e- s^-1 / (W m^-2 nm^-1).
    pub(crate) fn band_factors(&self, grid: &WavelengthGrid) -> Vec<[f64; 3]> {
        let qe = self.channel_qe(grid);
        let area = self.photodetector_area_m2();
        (0..grid.len())
            .map(|b| {
                let lambda_m = grid.wavelength_nm(b) * 1e-9;
                let photons_per_j = lambda_m / (PLANCK_J_S * SPEED_OF_LIGHT_M_PER_S);
                let k = photons_per_j * grid.step_nm * area;
                [qe[0][b] * k, qe[1][b] * k, qe[2][b] * k]
            })
            .collect()
    }

    /// Mean photo-electrons per pixel of each channel (r, g, b) for a uniform irradiance
    /// `irradiance_w_per_m2_nm` sampled on `grid`, in `exposure_s` (dark electrons not included):
    /// sum_lambda E QE_c lambda/(h c) d lambda x pitch^2 x fill factor x t.
    pub fn mean_electrons_uniform(
        &self,
        irradiance_w_per_m2_nm: &[f64],
        grid: &WavelengthGrid,
        exposure_s: f64,
    ) -> Result<[f64; 3]> {
        check_spectrum(irradiance_w_per_m2_nm, grid, "uniform irradiance")?;
        let f = self.band_factors(grid);
        let mut e = [0.0; 3];
        for (b, fb) in f.iter().enumerate() {
            for c in 0..3 {
                e[c] += fb[c] * irradiance_w_per_m2_nm[b] * exposure_s;
            }
        }
        Ok(e)
    }

    /// Electrons per second per pixel per unit spectral irradiance in each band, per filter of
    /// [`Sensor::cfa_layout`] (as [`Sensor::band_factors`]; that one is the Bayer hot path's).
    pub(crate) fn band_factors_filters(&self, grid: &WavelengthGrid) -> Vec<Vec<f64>> {
        let qe: Vec<Vec<f64>> = self
            .filter_qe_spectra()
            .iter()
            .map(|s| s.sample(grid))
            .collect();
        let area = self.photodetector_area_m2();
        (0..grid.len())
            .map(|b| {
                let lambda_m = grid.wavelength_nm(b) * 1e-9;
                let k = lambda_m / (PLANCK_J_S * SPEED_OF_LIGHT_M_PER_S) * grid.step_nm * area;
                qe.iter().map(|q| q[b] * k).collect()
            })
            .collect()
    }

    /// Per filter of [`Sensor::cfa_layout`] (its filter order), per band of `grid`: the
    /// photo-electrons per second one pixel collects per unit spectral irradiance in that band,
    /// e- s^-1 / (W m^-2 nm^-1) ([`Sensor::band_factors_filters`] by filter).
    pub fn electrons_per_irradiance(&self, grid: &WavelengthGrid) -> Vec<Vec<f64>> {
        let f = self.band_factors_filters(grid);
        let n = self.filter_qe_spectra().len();
        (0..n).map(|c| f.iter().map(|b| b[c]).collect()).collect()
    }

    /// The variance of the temporal noise a pixel has at zero photo-signal after `exposure_s`,
    /// electrons^2: read noise, DSNU, dark-current shot noise and quantization (1/12 DN^2 over
    /// K^2), each only when its switch is on (EMVA 1288 rel. 4.0 eq. 9 in electrons). DSNU is a
    /// fixed pattern here (drawn once from `fixed_pattern_seed`), not temporal noise, but in any
    /// one raw it hides render noise just as read noise does, so it counts toward the floor a
    /// render need not go below. A pixel of mean photo-signal `mu_e` adds `mu_e` (shot noise).
    pub fn noise_floor_variance_e2(&self, exposure_s: f64) -> f64 {
        let n = &self.noise;
        let per_e = 1.0 / self.conversion_gain_v_per_e;
        let read = if n.read {
            self.read_noise_v * per_e
        } else {
            0.0
        };
        let dsnu = if n.dsnu { self.dsnu_v * per_e } else { 0.0 };
        let dark = if n.shot {
            self.dark_electrons(exposure_s.max(0.0))
        } else {
            0.0
        };
        let k = self.k_dn_per_e();
        let quant = if n.quantization {
            1.0 / (12.0 * k * k)
        } else {
            0.0
        };
        read * read + dsnu * dsnu + dark + quant
    }

    /// [`Sensor::mean_electrons_uniform`] for every filter of [`Sensor::cfa_layout`], in its
    /// filter order (r, g, b, then e.g. w).
    pub fn mean_electrons_uniform_filters(
        &self,
        irradiance_w_per_m2_nm: &[f64],
        grid: &WavelengthGrid,
        exposure_s: f64,
    ) -> Result<Vec<f64>> {
        check_spectrum(irradiance_w_per_m2_nm, grid, "uniform irradiance")?;
        let f = self.band_factors_filters(grid);
        let mut e = vec![0.0; self.filter_qe_spectra().len()];
        for (b, fb) in f.iter().enumerate() {
            for (ec, fc) in e.iter_mut().zip(fb) {
                *ec += fc * irradiance_w_per_m2_nm[b] * exposure_s;
            }
        }
        Ok(e)
    }

    /// Least-squares weights (a, b, c) with QE_f ~= a QE_r + b QE_g + c QE_b over the QE
    /// wavelength samples, for filter `name` of the CFA (e.g. `w`): the RGBW -> RGB fusion's
    /// prediction of W from R, G, B (`camsim_isp::cfa_general::rgbw_to_rgb`). 3x3 normal
    /// equations solved by Cramer's rule.
    pub fn filter_from_rgb_weights(&self, name: &str) -> Result<[f64; 3]> {
        let layout = self.cfa_layout();
        let Some(i) = layout.filter_index(name) else {
            return Err(SensorError::input(
                "filter",
                format!("the CFA {} has no filter '{name}'", layout.name()),
            ));
        };
        let target = self.filter_qe_spectra()[i].values.clone();
        let basis: Vec<&[f64]> = self.qe.iter().map(|s| s.values.as_slice()).collect();
        let mut a = [[0.0f64; 3]; 3];
        let mut y = [0.0f64; 3];
        for k in 0..target.len() {
            for p in 0..3 {
                y[p] += basis[p][k] * target[k];
                for q in 0..3 {
                    a[p][q] += basis[p][k] * basis[q][k];
                }
            }
        }
        let det = |m: &[[f64; 3]; 3]| {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        };
        let d = det(&a);
        let scale = a
            .iter()
            .flatten()
            .map(|v| v.abs())
            .fold(0.0, f64::max)
            .powi(3);
        if d.abs() <= 1e-12 * scale || !d.is_finite() {
            return Err(SensorError::input(
                "filter",
                "the r, g, b QE curves are linearly dependent; no fit of another filter to them",
            ));
        }
        let mut w = [0.0; 3];
        for (c, wc) in w.iter_mut().enumerate() {
            let mut m = a;
            for r in 0..3 {
                m[r][c] = y[r];
            }
            *wc = det(&m) / d;
        }
        Ok(w)
    }

    /// Mean photons reaching the whole pixel area (pitch^2) of a uniform irradiance in `exposure_s`,
    /// wavelength-integrated: sum E lambda/(h c) d lambda x pitch^2 x t (EMVA 1288 mu_p).
    pub fn photons_per_pixel(
        &self,
        irradiance_w_per_m2_nm: &[f64],
        grid: &WavelengthGrid,
        exposure_s: f64,
    ) -> Result<f64> {
        check_spectrum(irradiance_w_per_m2_nm, grid, "uniform irradiance")?;
        let area = self.pixel_pitch_m * self.pixel_pitch_m;
        Ok((0..grid.len())
            .map(|b| {
                let lambda_m = grid.wavelength_nm(b) * 1e-9;
                irradiance_w_per_m2_nm[b] * grid.step_nm * lambda_m
                    / (PLANCK_J_S * SPEED_OF_LIGHT_M_PER_S)
            })
            .sum::<f64>()
            * area
            * exposure_s)
    }

    /// Predicted noise of a pixel whose mean signal is `mean_signal_dn_above_black` DN above the
    /// black level (dark signal included) after `exposure_s`, per source and total, in DN.
    /// EMVA 1288 rel. 4.0 eq. 9 with ISETCam's sources:
    /// var_DN = K^2 mu_e + (read_v dn_per_v / g)^2 + (dsnu_v dn_per_v / g)^2 + (prnu mean)^2 + 1/12,
    /// mu_e = photo + dark electrons, K = [`Sensor::k_dn_per_e`]. Switched-off sources give 0.
    /// Ignores clipping (valid well below the swing and above 0).
    pub fn predicted_noise_dn(
        &self,
        mean_signal_dn_above_black: f64,
        exposure_s: f64,
    ) -> NoiseBreakdown {
        let k = self.k_dn_per_e();
        let g = self.analog_gain;
        let dpv = self.dn_per_v();
        let mean = mean_signal_dn_above_black.max(0.0);
        let dark_e = self.dark_electrons(exposure_s.max(0.0));
        let total_e = mean / k;
        let photo_e = (total_e - dark_e).max(0.0);
        let n = &self.noise;
        let shot = if n.shot { k * photo_e.sqrt() } else { 0.0 };
        let dark = if n.shot {
            k * dark_e.min(total_e).sqrt()
        } else {
            0.0
        };
        let read = if n.read {
            self.read_noise_v * dpv / g
        } else {
            0.0
        };
        let dsnu = if n.dsnu { self.dsnu_v * dpv / g } else { 0.0 };
        let prnu = if n.prnu {
            self.prnu_fraction * mean
        } else {
            0.0
        };
        let quantization = if n.quantization {
            (1.0f64 / 12.0).sqrt()
        } else {
            0.0
        };
        let total = (shot * shot
            + dark * dark
            + read * read
            + dsnu * dsnu
            + prnu * prnu
            + quantization * quantization)
            .sqrt();
        NoiseBreakdown {
            shot,
            read,
            dsnu,
            prnu,
            dark,
            quantization,
            total,
        }
    }
}

pub(crate) fn check_spectrum(values: &[f64], grid: &WavelengthGrid, what: &str) -> Result<()> {
    if values.len() != grid.len() {
        return Err(SensorError::input(
            what,
            format!(
                "{} values for a {}-band wavelength grid",
                values.len(),
                grid.len()
            ),
        ));
    }
    if let Some((i, v)) = values
        .iter()
        .enumerate()
        .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
    {
        return Err(SensorError::input(
            what,
            format!(
                "value {v} at {} nm is not a finite number >= 0",
                grid.wavelength_nm(i)
            ),
        ));
    }
    Ok(())
}
