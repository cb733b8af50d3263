//! Frame series for an EMVA 1288 measurement: bright and dark stacks of a uniform irradiance at
//! several exposure times on a small window of the sensor (EMVA 1288 rel. 4.0, section 6:
//! photon transfer by varying the exposure time).

use crate::compute::{Capture, Exposure};
use crate::error::{Result, SensorError};
use crate::sensor::{check_spectrum, Sensor};
use camsim_core::{mem, RawImage, WavelengthGrid};

/// One illumination level of an EMVA 1288 series.
#[derive(Debug, Clone, PartialEq)]
pub struct EmvaLevel {
    /// Exposure time, s.
    pub exposure_s: f64,
    /// Mean photons reaching the area of one pixel (pitch^2, not only the photodetector),
    /// wavelength-integrated: EMVA 1288 mu_p = A E t lambda/(h c) summed over the spectrum.
    pub photons_per_pixel: f64,
    /// Sensor-plane photometric exposure, lux s: the irradiance's illuminance,
    /// 683 lm/W sum y_bar E dl (CIE 015:2018 eq. 7.1 with the photopic y_bar), times the exposure.
    pub exposure_lux_s: f64,
    /// Frames of the uniform irradiance.
    pub bright: Vec<RawImage>,
    /// Frames with no light (same exposure time), for the dark signal and the dark noise.
    pub dark: Vec<RawImage>,
}

impl Sensor {
    /// An EMVA 1288 series: for each exposure time, `frames_per_level` (>= 2) frames of the uniform
    /// irradiance `irradiance_w_per_m2_nm` (on `grid`) and as many dark frames, computed on the
    /// top-left `rows` x `cols` window of this sensor (same fixed pattern as the full sensor there).
    /// Temporal noise is keyed on `seed` and on a frame index unique within the series.
    #[allow(clippy::too_many_arguments)]
    pub fn emva_series(
        &self,
        grid: &WavelengthGrid,
        irradiance_w_per_m2_nm: &[f64],
        exposures_s: &[f64],
        frames_per_level: usize,
        rows: usize,
        cols: usize,
        seed: u64,
    ) -> Result<Vec<EmvaLevel>> {
        check_spectrum(irradiance_w_per_m2_nm, grid, "EMVA irradiance")?;
        if frames_per_level < 2 {
            return Err(SensorError::input(
                "frames_per_level",
                format!("must be at least 2, got {frames_per_level}"),
            ));
        }
        if rows == 0 || cols == 0 || rows > self.rows() || cols > self.cols() {
            return Err(SensorError::input(
                "EMVA window",
                format!(
                    "{rows} x {cols} must be at least 1 x 1 and fit the {} x {} sensor",
                    self.rows(),
                    self.cols()
                ),
            ));
        }
        if let Some(t) = exposures_s.iter().find(|t| !(t.is_finite() && **t >= 0.0)) {
            return Err(SensorError::input(
                "exposures_s",
                format!("{t} s is not a finite time >= 0"),
            ));
        }
        let n = rows * cols;
        let frames = 2 * frames_per_level * exposures_s.len();
        mem::MemoryBudget::new(format!(
            "the EMVA series ({frames} frames of {rows} x {cols})"
        ))
        .bytes("frames", (n as u64) * 2 * frames as u64)
        .f32s("bright and dark rates", 2 * n)
        .check("use a smaller window (rows and cols), fewer levels or fewer frames per level")?;
        // Uniform field: every pixel of channel c collects the same electron rate.
        let mut bright_rate = vec![0.0f32; n];
        if let Some(layout) = &self.layout {
            let per_filter =
                self.mean_electrons_uniform_filters(irradiance_w_per_m2_nm, grid, 1.0)?;
            for r in 0..rows {
                for c in 0..cols {
                    bright_rate[r * cols + c] = per_filter[layout.filter_at(r, c)] as f32;
                }
            }
        } else {
            let per_channel = self.mean_electrons_uniform(irradiance_w_per_m2_nm, grid, 1.0)?;
            for r in 0..rows {
                for c in 0..cols {
                    bright_rate[r * cols + c] =
                        per_channel[self.cfa.channel_at(r, c).index()] as f32;
                }
            }
        }
        let dark_rate = vec![0.0f32; n];
        let illuminance_lux =
            camsim_core::colorimetry::luminance_cd_m2(irradiance_w_per_m2_nm, grid);
        let f = frames_per_level as u64;
        let mut out = Vec::with_capacity(exposures_s.len());
        for (level, &t) in exposures_s.iter().enumerate() {
            let capture = Capture {
                exposure: Exposure::Seconds(t),
                frames: frames_per_level,
                seed,
                global_reset: None,
                light: None,
            };
            let base = level as u64 * 2 * f;
            let bright = self.capture_from_rate(&bright_rate, rows, cols, &capture, base)?;
            let dark = self.capture_from_rate(&dark_rate, rows, cols, &capture, base + f)?;
            out.push(EmvaLevel {
                exposure_s: t,
                photons_per_pixel: self.photons_per_pixel(irradiance_w_per_m2_nm, grid, t)?,
                exposure_lux_s: illuminance_lux * t,
                bright: bright.raw,
                dark: dark.raw,
            });
        }
        Ok(out)
    }
}

impl Sensor {
    /// A uniform irradiance (W/(m^2 nm) on `grid`) made of three narrow lines at 460, 540 and
    /// 620 nm, weighted so that the R, G and B channels all collect `rate_e_per_s` electrons per
    /// second. An EMVA 1288 series lit with it saturates every channel at the same exposure
    /// (EMVA 1288 4.0 measures a colour sensor per channel; one light for all three is a
    /// convenience that keeps one exposure ladder). Solves the 3x3 system by Cramer's rule.
    pub fn balanced_emva_irradiance(
        &self,
        grid: &WavelengthGrid,
        rate_e_per_s: f64,
    ) -> Result<Vec<f64>> {
        let bands = [460.0, 540.0, 620.0].map(|w| grid.band_of(w));
        let bands =
            match bands {
                [Some(a), Some(b), Some(c)] => [a, b, c],
                _ => return Err(SensorError::input(
                    "EMVA light",
                    "the wavelength grid needs bands at 460, 540 and 620 nm for the balanced light",
                )),
            };
        // a[c][k]: electrons/s of channel c per W/(m^2 nm) in line k.
        let mut a = [[0.0; 3]; 3];
        for (k, b) in bands.iter().enumerate() {
            let mut e = vec![0.0; grid.len()];
            e[*b] = 1.0;
            let r = self.mean_electrons_uniform(&e, grid, 1.0)?;
            for (c, row) in a.iter_mut().enumerate() {
                row[k] = r[c];
            }
        }
        let det = |m: &[[f64; 3]; 3]| {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        };
        let d = det(&a);
        let mut irr = vec![0.0; grid.len()];
        for (k, b) in bands.iter().enumerate() {
            let mut m = a;
            for row in m.iter_mut() {
                row[k] = rate_e_per_s;
            }
            let x = det(&m) / d;
            if !(x > 0.0 && x.is_finite()) {
                return Err(SensorError::input(
                    "EMVA light",
                    format!("no non-negative mix of 460/540/620 nm lines balances this sensor's channels (line {k} weight {x})"),
                ));
            }
            irr[*b] = x;
        }
        Ok(irr)
    }
}
