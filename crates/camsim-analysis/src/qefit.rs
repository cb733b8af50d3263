//! Sensor QE correction (Lyu et al., "Validation of image systems simulation technology using a
//! Cornell Box", eq. 1): predicted RGB of chart patches from a QE by photon counting, and the 3x3
//! matrix M with `[r', g', b'] = [r, g, b] M` that brings predictions to measurements.
//!
//! The prediction is linear in the QE, so the prediction with the transformed QE `QE M` is the
//! original prediction times M: the fit is a linear least-squares problem per output channel j,
//! `measured[:, j] ~ predicted * M[:, j]`.

use crate::error::{AnalysisError, Result};
use crate::nnls::{lstsq, nnls};
use camsim_core::{units, WavelengthGrid};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// The form of M being fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MatrixForm {
    /// All nine entries free (ordinary least squares).
    Unconstrained,
    /// Only the diagonal (a gain per channel), least squares.
    Diagonal,
    /// The paper's form, non-negative (NNLS):
    /// `M = [[a, 0, 0], [b, c, 0], [0, d, e]]`, i.e. r' = a r + b g, g' = c g + d b, b' = e b
    /// (entries `M[0][0]`, `M[1][0]`, `M[1][1]`, `M[2][1]`, `M[2][2]`, as the paper prints M).
    PaperLowerNonNegative,
}

impl MatrixForm {
    /// Which entries `M[i][j]` are free.
    pub fn mask(self) -> [[bool; 3]; 3] {
        match self {
            MatrixForm::Unconstrained => [[true; 3]; 3],
            MatrixForm::Diagonal => [
                [true, false, false],
                [false, true, false],
                [false, false, true],
            ],
            MatrixForm::PaperLowerNonNegative => [
                [true, false, false],
                [true, true, false],
                [false, true, true],
            ],
        }
    }
    /// Whether the free entries are constrained to be >= 0.
    pub fn non_negative(self) -> bool {
        matches!(self, MatrixForm::PaperLowerNonNegative)
    }
}

/// The paper's printed M (Lyu et al. 2022, section "Sensor modelling").
pub const PAPER_M: [[f64; 3]; 3] = [[0.532, 0.0, 0.0], [0.06, 0.70, 0.0], [0.0, 0.36, 0.84]];

/// Result of fitting M.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QeFit {
    /// The form fitted.
    pub form: MatrixForm,
    /// M, row-major: `m[i][j]` multiplies input channel i into output channel j.
    pub m: [[f64; 3]; 3],
    /// RMS of all residuals (measured - predicted) before the correction (M = identity), in the
    /// unit of the measurements.
    pub rms_before: f64,
    /// RMS of all residuals after the correction.
    pub rms_after: f64,
    /// RMS before, relative to the RMS of the measurements.
    pub relative_rms_before: f64,
    /// RMS after, relative to the RMS of the measurements.
    pub relative_rms_after: f64,
    /// Per-patch residuals before (measured - predicted).
    pub residuals_before: Vec<[f64; 3]>,
    /// Per-patch residuals after (measured - predicted M).
    pub residuals_after: Vec<[f64; 3]>,
}

/// `rgb M` for each row (row vector times matrix).
pub fn apply_matrix(rgb: &[[f64; 3]], m: &[[f64; 3]; 3]) -> Vec<[f64; 3]> {
    rgb.iter()
        .map(|p| {
            let mut o = [0.0; 3];
            for (j, oj) in o.iter_mut().enumerate() {
                *oj = (0..3).map(|i| p[i] * m[i][j]).sum();
            }
            o
        })
        .collect()
}

/// The transformed QE curves `[r', g', b'] = [r, g, b] M` (paper eq. 1), per wavelength.
pub fn transform_qe(qe: &[Vec<f64>; 3], m: &[[f64; 3]; 3]) -> Result<[Vec<f64>; 3]> {
    let n = qe[0].len();
    if qe.iter().any(|c| c.len() != n) {
        return Err(AnalysisError::invalid(
            "qe",
            "the three channels have different numbers of samples",
        ));
    }
    let mut out = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    for k in 0..n {
        for (j, o) in out.iter_mut().enumerate() {
            o[k] = (0..3).map(|i| qe[i][k] * m[i][j]).sum();
        }
    }
    Ok(out)
}

/// Relative RMS difference per channel between the transformed curves `source M` and `target`
/// over the wavelength samples: `sqrt(sum (source M - target)^2 / sum target^2)` (0 for an
/// all-zero target channel). How far a correction matrix is from turning one QE into another.
pub fn qe_relative_rms_difference(
    source: &[Vec<f64>; 3],
    target: &[Vec<f64>; 3],
    m: &[[f64; 3]; 3],
) -> Result<[f64; 3]> {
    let transformed = transform_qe(source, m)?;
    if target.iter().any(|c| c.len() != transformed[0].len()) {
        return Err(AnalysisError::invalid(
            "qe",
            "source and target curves have different numbers of samples",
        ));
    }
    Ok([0, 1, 2].map(|j| {
        let num: f64 = transformed[j]
            .iter()
            .zip(&target[j])
            .map(|(p, t)| (p - t).powi(2))
            .sum();
        let den: f64 = target[j].iter().map(|t| t * t).sum();
        if den > 0.0 {
            (num / den).sqrt()
        } else {
            0.0
        }
    }))
}

/// Predicted channel responses of patches by photon counting (ISETCam sensorCompute, noise-free):
/// `rgb_c = scale * sum_lambda L(lambda) * lambda / (h c) * QE_c(lambda) * step_nm`.
///
/// `radiances[p]` is patch p's spectral radiance in W/(sr m^2 nm) on `grid`; `qe` the channel QE
/// (fraction, IR filter included) on `grid`. The sum is photons/(s sr m^2); `scale_sr_m2_s` is the
/// etendue times exposure (sr m^2 s), with any gain (DN/e-) folded in by the caller, so the
/// result is in electrons (or DN).
pub fn predict_rgb(
    qe: &[Vec<f64>; 3],
    grid: &WavelengthGrid,
    radiances: &[Vec<f64>],
    scale_sr_m2_s: f64,
) -> Result<Vec<[f64; 3]>> {
    let n = grid.len();
    for (c, q) in qe.iter().enumerate() {
        if q.len() != n {
            return Err(AnalysisError::invalid(
                "qe",
                format!("channel {c} has {} samples for a {n}-band grid", q.len()),
            ));
        }
        if q.iter().any(|v| !v.is_finite()) {
            return Err(AnalysisError::invalid(
                "qe",
                format!("channel {c} holds values that are not finite"),
            ));
        }
    }
    if !scale_sr_m2_s.is_finite() {
        return Err(AnalysisError::invalid(
            "qe prediction",
            format!("scale {scale_sr_m2_s} is not finite"),
        ));
    }
    // Photons per joule at each band, times the band width.
    let w: Vec<f64> = (0..n)
        .map(|b| units::energy_to_photons(1.0, grid.wavelength_nm(b)) * grid.step_nm)
        .collect();
    radiances
        .iter()
        .enumerate()
        .map(|(p, l)| {
            if l.len() != n {
                return Err(AnalysisError::invalid(
                    "radiance",
                    format!("patch {p} has {} samples for a {n}-band grid", l.len()),
                ));
            }
            let mut o = [0.0; 3];
            for (c, oc) in o.iter_mut().enumerate() {
                *oc = scale_sr_m2_s * (0..n).map(|b| l[b] * w[b] * qe[c][b]).sum::<f64>();
            }
            Ok(o)
        })
        .collect()
}

fn rms(res: &[[f64; 3]]) -> f64 {
    if res.is_empty() {
        return 0.0;
    }
    (res.iter()
        .flat_map(|r| r.iter())
        .map(|v| v * v)
        .sum::<f64>()
        / (3 * res.len()) as f64)
        .sqrt()
}

fn residuals(measured: &[[f64; 3]], predicted: &[[f64; 3]]) -> Vec<[f64; 3]> {
    measured
        .iter()
        .zip(predicted)
        .map(|(m, p)| [m[0] - p[0], m[1] - p[1], m[2] - p[2]])
        .collect()
}

/// Fit M (of the given form) by least squares so that `measured ~ predicted M`, with RMS error
/// and per-patch residuals before and after. `measured` and `predicted` are n x 3 (one row per
/// patch and light), in the same unit.
pub fn fit_qe_matrix(
    measured: &[[f64; 3]],
    predicted: &[[f64; 3]],
    form: MatrixForm,
) -> Result<QeFit> {
    let n = measured.len();
    if n != predicted.len() {
        return Err(AnalysisError::invalid(
            "qe fit",
            format!("{n} measured patches but {} predicted", predicted.len()),
        ));
    }
    if n < 3 {
        return Err(AnalysisError::invalid(
            "qe fit",
            format!("{n} patches are too few to fit a 3x3 matrix"),
        ));
    }
    for (i, (m, p)) in measured.iter().zip(predicted).enumerate() {
        if m.iter().chain(p.iter()).any(|v| !v.is_finite()) {
            return Err(AnalysisError::invalid(
                "qe fit",
                format!("patch {i} holds values that are not finite"),
            ));
        }
    }
    let mask = form.mask();
    let mut m = [[0.0; 3]; 3];
    for j in 0..3 {
        let inputs: Vec<usize> = (0..3).filter(|i| mask[*i][j]).collect();
        let a = DMatrix::from_fn(n, inputs.len(), |r, k| predicted[r][inputs[k]]);
        let b = DVector::from_fn(n, |r, _| measured[r][j]);
        let x = if form.non_negative() {
            nnls(&a, &b)?
        } else {
            lstsq(&a, &b)?
        };
        for (k, i) in inputs.iter().enumerate() {
            m[*i][j] = x[k];
        }
    }
    let before = residuals(measured, predicted);
    let after = residuals(measured, &apply_matrix(predicted, &m));
    let scale = rms(measured).max(1e-300);
    Ok(QeFit {
        form,
        m,
        rms_before: rms(&before),
        rms_after: rms(&after),
        relative_rms_before: rms(&before) / scale,
        relative_rms_after: rms(&after) / scale,
        residuals_before: before,
        residuals_after: after,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn qe_difference_is_the_relative_rms_of_the_residual() {
        let src = [
            vec![1.0, 2.0, 3.0],
            vec![0.5, 0.5, 0.5],
            vec![0.0, 1.0, 0.0],
        ];
        // target = 2 x source: M = 2 I matches exactly; M = I leaves |x - 2x| / |2x| = 1/2.
        let target = src
            .clone()
            .map(|c| c.iter().map(|v| 2.0 * v).collect::<Vec<_>>());
        let two = [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 2.0]];
        let one = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        assert_eq!(
            qe_relative_rms_difference(&src, &target, &two).unwrap(),
            [0.0; 3]
        );
        for e in qe_relative_rms_difference(&src, &target, &one).unwrap() {
            assert!((e - 0.5).abs() < 1e-15, "{e}");
        }
        // Mismatched lengths are an error, not a panic.
        let short = [vec![1.0], vec![1.0], vec![1.0]];
        assert!(qe_relative_rms_difference(&src, &short, &one).is_err());
    }

    #[test]
    fn predict_rgb_counts_photons() {
        // One band at 500 nm, 10 nm wide: L = 1e-3 W/(sr m^2 nm), QE 0.5, scale 2 sr m^2 s:
        // photons = 2 * 1e-3 * 10 * 0.5 / (h c / 500 nm).
        let grid = WavelengthGrid::new(500.0, 500.0, 10.0).unwrap();
        let grid = WavelengthGrid {
            step_nm: 10.0,
            ..grid
        };
        let qe = [vec![0.5], vec![0.25], vec![0.0]];
        let p = predict_rgb(&qe, &grid, &[vec![1e-3]], 2.0).unwrap();
        let e = units::photon_energy_j(500.0);
        assert!((p[0][0] - 2.0 * 1e-3 * 10.0 * 0.5 / e).abs() < 1e-9 * p[0][0]);
        assert!((p[0][1] / p[0][0] - 0.5).abs() < 1e-12 && p[0][2] == 0.0);
        assert!(predict_rgb(&qe, &grid, &[vec![1.0, 2.0]], 1.0).is_err());
    }

    #[test]
    fn the_transformed_qe_predicts_prediction_times_m() {
        let grid = WavelengthGrid::new(400.0, 700.0, 10.0).unwrap();
        let qe = [0.0, 1.0, 2.0].map(|c: f64| {
            (0..31)
                .map(|b| ((b as f64 * 0.3 + c).sin() + 1.2) * 0.3)
                .collect::<Vec<_>>()
        });
        let rad: Vec<Vec<f64>> = (0..5)
            .map(|p| {
                (0..31)
                    .map(|b| 1e-3 * (1.0 + ((p * b) as f64 * 0.1).cos()))
                    .collect()
            })
            .collect();
        let p0 = predict_rgb(&qe, &grid, &rad, 1e-12).unwrap();
        let p1 = predict_rgb(&transform_qe(&qe, &PAPER_M).unwrap(), &grid, &rad, 1e-12).unwrap();
        for (a, b) in apply_matrix(&p0, &PAPER_M).iter().zip(&p1) {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() < 1e-12 * b[c].abs().max(1.0));
            }
        }
    }
}
