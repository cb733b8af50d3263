//! Uniform wavelength grids (ISETCam's `wave` vector: start, step, count).

use crate::error::{CoreError, Result};
use serde::{Deserialize, Serialize};

/// A uniformly spaced set of wavelengths, in nanometres. The default is ISETCam's 400-700 nm
/// every 10 nm (31 bands). Each band represents `step_nm` of spectrum centred on its wavelength,
/// so sums over the grid approximate integrals as `sum f(lambda_i) * step_nm`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct WavelengthGrid {
    /// Centre of the first band, nm.
    pub start_nm: f64,
    /// Spacing of the band centres (and width of each band), nm; > 0.
    pub step_nm: f64,
    /// Number of bands (>= 1).
    pub count: usize,
}

impl Default for WavelengthGrid {
    fn default() -> Self {
        WavelengthGrid {
            start_nm: 400.0,
            step_nm: 10.0,
            count: 31,
        }
    }
}

impl WavelengthGrid {
    /// Grid from `start_nm` to `end_nm` inclusive every `step_nm`.
    pub fn new(start_nm: f64, end_nm: f64, step_nm: f64) -> Result<Self> {
        if !(start_nm.is_finite() && end_nm.is_finite() && step_nm.is_finite()) {
            return Err(CoreError::invalid(
                "wavelength grid",
                "start, end and step must be finite numbers",
            ));
        }
        if start_nm <= 0.0 || step_nm <= 0.0 || end_nm < start_nm {
            return Err(CoreError::invalid(
                "wavelength grid",
                format!("need 0 < start_nm <= end_nm and step_nm > 0, got start {start_nm}, end {end_nm}, step {step_nm}"),
            ));
        }
        let n = ((end_nm - start_nm) / step_nm + 1e-6).floor() as usize + 1;
        if n > 10_000 {
            return Err(CoreError::invalid(
                "wavelength grid",
                format!("{n} bands is more than 10000"),
            ));
        }
        Ok(WavelengthGrid {
            start_nm,
            step_nm,
            count: n,
        })
    }

    /// Check a grid read from a config: positive step, at least one band.
    pub fn validate(&self) -> Result<()> {
        WavelengthGrid::new(self.start_nm, self.end_nm(), self.step_nm).map(|_| ())?;
        if self.count == 0 {
            return Err(CoreError::invalid(
                "wavelength grid",
                "count must be at least 1",
            ));
        }
        Ok(())
    }

    pub fn end_nm(&self) -> f64 {
        self.start_nm + self.step_nm * (self.count.saturating_sub(1)) as f64
    }

    pub fn len(&self) -> usize {
        self.count
    }

    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    pub fn wavelength_nm(&self, band: usize) -> f64 {
        self.start_nm + self.step_nm * band as f64
    }

    pub fn wavelengths_nm(&self) -> Vec<f64> {
        (0..self.count).map(|i| self.wavelength_nm(i)).collect()
    }

    /// Index of the band whose centre equals `wavelength_nm` (within 1e-6 nm), if any.
    pub fn band_of(&self, wavelength_nm: f64) -> Option<usize> {
        let x = (wavelength_nm - self.start_nm) / self.step_nm;
        let i = x.round();
        if i >= 0.0 && (i as usize) < self.count && (x - i).abs() * self.step_nm < 1e-6 {
            Some(i as usize)
        } else {
            None
        }
    }

    /// Fit a uniform grid to a list of wavelengths (as read from a file); error if not uniform.
    pub fn from_wavelengths(wavelengths_nm: &[f64]) -> Result<Self> {
        match wavelengths_nm.len() {
            0 => Err(CoreError::invalid("wavelength grid", "no wavelengths")),
            1 => Ok(WavelengthGrid {
                start_nm: wavelengths_nm[0],
                step_nm: 1.0,
                count: 1,
            }),
            n => {
                let start = wavelengths_nm[0];
                let step = (wavelengths_nm[n - 1] - start) / (n - 1) as f64;
                if step <= 0.0 {
                    return Err(CoreError::invalid(
                        "wavelength grid",
                        "wavelengths must increase",
                    ));
                }
                for (i, w) in wavelengths_nm.iter().enumerate() {
                    if (w - (start + step * i as f64)).abs() > 1e-3 * step {
                        return Err(CoreError::invalid(
                            "wavelength grid",
                            format!("wavelengths are not uniformly spaced (sample {i} is {w} nm)"),
                        ));
                    }
                }
                Ok(WavelengthGrid {
                    start_nm: start,
                    step_nm: step,
                    count: n,
                })
            }
        }
    }

    /// True when both grids have the same wavelengths (to 1e-6 nm).
    pub fn same_as(&self, other: &WavelengthGrid) -> bool {
        self.count == other.count
            && (self.start_nm - other.start_nm).abs() < 1e-6
            && (self.step_nm - other.step_nm).abs() < 1e-6
    }

    /// Error naming `what` when the grids differ.
    pub fn require_same(&self, other: &WavelengthGrid, what: &str) -> Result<()> {
        if self.same_as(other) {
            Ok(())
        } else {
            Err(CoreError::invalid(
                what,
                format!(
                    "wavelength grids differ: {}-{} nm every {} nm vs {}-{} nm every {} nm",
                    self.start_nm,
                    self.end_nm(),
                    self.step_nm,
                    other.start_nm,
                    other.end_nm(),
                    other.step_nm
                ),
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_isetcam_31_bands() {
        let g = WavelengthGrid::default();
        assert_eq!(g.len(), 31);
        assert_eq!(g.end_nm(), 700.0);
        assert_eq!(g.band_of(550.0), Some(15));
        assert_eq!(g.band_of(555.0), None);
    }

    #[test]
    fn new_counts_inclusive_end_and_rejects_bad_input() {
        assert_eq!(WavelengthGrid::new(380.0, 780.0, 5.0).unwrap().len(), 81);
        assert!(WavelengthGrid::new(400.0, 700.0, 0.0).is_err());
        assert!(WavelengthGrid::new(700.0, 400.0, 10.0).is_err());
        assert!(WavelengthGrid::new(f64::NAN, 700.0, 10.0).is_err());
    }

    #[test]
    fn from_wavelengths_detects_non_uniform() {
        assert!(WavelengthGrid::from_wavelengths(&[400.0, 410.0, 430.0]).is_err());
        let g = WavelengthGrid::from_wavelengths(&[400.0, 410.0, 420.0]).unwrap();
        assert!(g.same_as(&WavelengthGrid::new(400.0, 420.0, 10.0).unwrap()));
    }
}
