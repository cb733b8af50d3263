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
            return Err(SensorError::input("frames_per_level", format!("must be at least 2, got {frames_per_level}")));
        }
        if rows == 0 || cols == 0 || rows > self.rows() || cols > self.cols() {
            return Err(SensorError::input(
                "EMVA window",
                format!("{rows} x {cols} must be at least 1 x 1 and fit the {} x {} sensor", self.rows(), self.cols()),
            ));
        }
        if let Some(t) = exposures_s.iter().find(|t| !(t.is_finite() && **t >= 0.0)) {
            return Err(SensorError::input("exposures_s", format!("{t} s is not a finite time >= 0")));
        }
        let n = rows * cols;
        mem::check_alloc(
            (n as u64) * 2 * 2 * frames_per_level as u64 * exposures_s.len() as u64 + n as u64 * 8,
            "the EMVA frame series",
        )?;
        // Uniform field: every pixel of channel c collects the same electron rate.
        let per_channel = self.mean_electrons_uniform(irradiance_w_per_m2_nm, grid, 1.0)?;
        let mut bright_rate = vec![0.0f32; n];
        for r in 0..rows {
            for c in 0..cols {
                bright_rate[r * cols + c] = per_channel[self.cfa.channel_at(r, c).index()] as f32;
            }
        }
        let dark_rate = vec![0.0f32; n];
        let f = frames_per_level as u64;
        let mut out = Vec::with_capacity(exposures_s.len());
        for (level, &t) in exposures_s.iter().enumerate() {
            let capture = Capture { exposure: Exposure::Seconds(t), frames: frames_per_level, seed };
            let base = level as u64 * 2 * f;
            let bright = self.capture_from_rate(&bright_rate, rows, cols, &capture, base)?;
            let dark = self.capture_from_rate(&dark_rate, rows, cols, &capture, base + f)?;
            out.push(EmvaLevel {
                exposure_s: t,
                photons_per_pixel: self.photons_per_pixel(irradiance_w_per_m2_nm, grid, t)?,
                bright: bright.raw,
                dark: dark.raw,
            });
        }
        Ok(out)
    }
}
