//! Sampled spectra with linear interpolation (ISETCam's `interp1(..., 'linear', 0)` behaviour:
//! zero outside the sampled range unless asked to hold the end values).

use crate::error::{CoreError, Result};
use crate::grid::WavelengthGrid;
use serde::{Deserialize, Serialize};

/// What to return outside the sampled wavelength range.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Extrapolation {
    /// 0 outside the range (a filter that passes nothing there; ISETCam's default).
    #[default]
    Zero,
    /// Hold the first / last value (a reflectance measured over a slightly shorter range).
    Hold,
}

/// A spectrum sampled at strictly increasing wavelengths (nm). The unit of `values` is whatever
/// the owner says (W/(sr m^2 nm), reflectance, QE fraction); the type itself is unit-agnostic.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Spectrum {
    pub wavelengths_nm: Vec<f64>,
    pub values: Vec<f64>,
    #[serde(default)]
    pub extrapolation: Extrapolation,
}

impl Spectrum {
    /// Build a spectrum, checking lengths, finiteness and increasing wavelengths. `what` names it
    /// in error messages (a file name, a config key).
    pub fn new(wavelengths_nm: Vec<f64>, values: Vec<f64>, what: &str) -> Result<Self> {
        if wavelengths_nm.len() != values.len() {
            return Err(CoreError::invalid(
                what,
                format!(
                    "{} wavelengths but {} values",
                    wavelengths_nm.len(),
                    values.len()
                ),
            ));
        }
        if wavelengths_nm.is_empty() {
            return Err(CoreError::invalid(what, "spectrum has no samples"));
        }
        for (i, (w, v)) in wavelengths_nm.iter().zip(&values).enumerate() {
            if !w.is_finite() || *w <= 0.0 {
                return Err(CoreError::invalid(
                    what,
                    format!("wavelength {i} is {w}, not a positive number"),
                ));
            }
            if !v.is_finite() {
                return Err(CoreError::invalid(
                    what,
                    format!("value at {w} nm is {v}, not a finite number"),
                ));
            }
        }
        if wavelengths_nm.windows(2).any(|p| p[1] <= p[0]) {
            return Err(CoreError::invalid(
                what,
                "wavelengths must be strictly increasing",
            ));
        }
        Ok(Spectrum {
            wavelengths_nm,
            values,
            extrapolation: Extrapolation::Zero,
        })
    }

    /// A spectrum already sampled on `grid`.
    pub fn on_grid(grid: &WavelengthGrid, values: Vec<f64>) -> Self {
        assert_eq!(
            grid.len(),
            values.len(),
            "on_grid: values must match the grid"
        );
        Spectrum {
            wavelengths_nm: grid.wavelengths_nm(),
            values,
            extrapolation: Extrapolation::Zero,
        }
    }

    /// The same value at every wavelength of `grid` (an equal-energy spectrum, a grey reflectance).
    pub fn constant(grid: &WavelengthGrid, value: f64) -> Self {
        Spectrum::on_grid(grid, vec![value; grid.len()])
    }

    /// Build from a static table of (wavelength_nm, value) pairs.
    pub fn from_pairs(pairs: &[(f64, f64)]) -> Self {
        Spectrum {
            wavelengths_nm: pairs.iter().map(|p| p.0).collect(),
            values: pairs.iter().map(|p| p.1).collect(),
            extrapolation: Extrapolation::Zero,
        }
    }

    pub fn with_extrapolation(mut self, e: Extrapolation) -> Self {
        self.extrapolation = e;
        self
    }

    /// Error naming `what` if any value is negative (radiances, reflectances, QE must not be).
    pub fn require_non_negative(&self, what: &str) -> Result<()> {
        if let Some((w, v)) = self
            .wavelengths_nm
            .iter()
            .zip(&self.values)
            .find(|(_, v)| **v < 0.0)
        {
            return Err(CoreError::invalid(
                what,
                format!("negative value {v} at {w} nm"),
            ));
        }
        Ok(())
    }

    /// Linear interpolation at `wavelength_nm`.
    pub fn eval(&self, wavelength_nm: f64) -> f64 {
        let w = &self.wavelengths_nm;
        let n = w.len();
        if n == 1 {
            return if (wavelength_nm - w[0]).abs() < 1e-9
                || self.extrapolation == Extrapolation::Hold
            {
                self.values[0]
            } else {
                0.0
            };
        }
        if wavelength_nm < w[0] || wavelength_nm > w[n - 1] {
            // Allow tiny round-off at the ends.
            let tol = 1e-9 * wavelength_nm.abs().max(1.0);
            if wavelength_nm >= w[0] - tol && wavelength_nm < w[0] {
                return self.values[0];
            }
            if wavelength_nm <= w[n - 1] + tol && wavelength_nm > w[n - 1] {
                return self.values[n - 1];
            }
            return match self.extrapolation {
                Extrapolation::Zero => 0.0,
                Extrapolation::Hold => {
                    if wavelength_nm < w[0] {
                        self.values[0]
                    } else {
                        self.values[n - 1]
                    }
                }
            };
        }
        // First index with w[i] >= wavelength.
        let i = w.partition_point(|x| *x < wavelength_nm);
        if i == 0 {
            return self.values[0];
        }
        let (w0, w1) = (w[i - 1], w[i]);
        let t = (wavelength_nm - w0) / (w1 - w0);
        self.values[i - 1] * (1.0 - t) + self.values[i] * t
    }

    /// Values at every wavelength of `grid` (linear resampling).
    pub fn sample(&self, grid: &WavelengthGrid) -> Vec<f64> {
        (0..grid.len())
            .map(|i| self.eval(grid.wavelength_nm(i)))
            .collect()
    }

    /// This spectrum resampled onto `grid`.
    pub fn resample(&self, grid: &WavelengthGrid) -> Spectrum {
        Spectrum::on_grid(grid, self.sample(grid)).with_extrapolation(self.extrapolation)
    }

    /// Product of two spectra sampled on `grid`.
    pub fn product_on(&self, other: &Spectrum, grid: &WavelengthGrid) -> Vec<f64> {
        (0..grid.len())
            .map(|i| {
                let w = grid.wavelength_nm(i);
                self.eval(w) * other.eval(w)
            })
            .collect()
    }

    /// Multiply every value by `k`.
    pub fn scaled(mut self, k: f64) -> Spectrum {
        self.values.iter_mut().for_each(|v| *v *= k);
        self
    }

    pub fn max_value(&self) -> f64 {
        self.values
            .iter()
            .cloned()
            .fold(f64::NEG_INFINITY, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_interpolation_is_exact_for_a_line() {
        let s = Spectrum::new(vec![400.0, 500.0, 700.0], vec![1.0, 2.0, 4.0], "t").unwrap();
        assert!((s.eval(450.0) - 1.5).abs() < 1e-12);
        assert!((s.eval(600.0) - 3.0).abs() < 1e-12);
        assert_eq!(s.eval(700.0), 4.0);
        assert_eq!(s.eval(399.0), 0.0);
        assert_eq!(
            s.clone()
                .with_extrapolation(Extrapolation::Hold)
                .eval(800.0),
            4.0
        );
    }

    #[test]
    fn rejects_bad_spectra() {
        assert!(Spectrum::new(vec![400.0, 410.0], vec![1.0], "t").is_err());
        assert!(Spectrum::new(vec![410.0, 400.0], vec![1.0, 1.0], "t").is_err());
        assert!(Spectrum::new(vec![400.0, 410.0], vec![1.0, f64::NAN], "t").is_err());
        let neg = Spectrum::new(vec![400.0, 410.0], vec![1.0, -1.0], "t").unwrap();
        assert!(neg.require_non_negative("t").is_err());
    }

    #[test]
    fn resampling_preserves_samples_on_the_same_grid() {
        let g = WavelengthGrid::default();
        let s = Spectrum::on_grid(&g, (0..31).map(|i| (i * i) as f64).collect());
        assert_eq!(s.sample(&g), s.values);
    }
}
