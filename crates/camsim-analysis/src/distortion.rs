//! Lens distortion as OpenCV's camera model writes it (Brown-Conrady: three radial and two
//! tangential coefficients; Brown 1966, "Decentering distortion of lenses"; the order and signs of
//! OpenCV's `calibrateCamera` documentation), fitted to a distortion map so the camera matrices
//! camsim writes can be used by tools that take `K` and `(k1, k2, p1, p2, k3)`.
//!
//! With normalized undistorted coordinates (x, y) = (X / Z, Y / Z) and r^2 = x^2 + y^2:
//! x_d = x (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2),
//! y_d = y (1 + k1 r^2 + k2 r^4 + k3 r^6) + p1 (r^2 + 2 y^2) + 2 p2 x y,
//! and the pixel is K (x_d, y_d, 1). The model is linear in the coefficients, so the fit is one
//! linear least-squares solve.

use crate::error::{AnalysisError, Result};
use nalgebra::{DMatrix, DVector};

/// OpenCV's five distortion coefficients (`distCoeffs` = [k1, k2, p1, p2, k3]).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct OpenCvDistortion {
    pub k1: f64,
    pub k2: f64,
    pub p1: f64,
    pub p2: f64,
    pub k3: f64,
}

impl OpenCvDistortion {
    /// The distorted normalized coordinates of undistorted `[x, y]`.
    pub fn apply(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        [
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        ]
    }

    /// The coefficients in OpenCV's order, `[k1, k2, p1, p2, k3]`.
    pub fn coefficients(&self) -> [f64; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }
}

/// Least-squares coefficients taking each `undistorted[i]` to `distorted[i]` (normalized
/// coordinates). Needs at least 5 pairs (3 are not enough to separate the terms); errors name the
/// problem.
pub fn fit_opencv(undistorted: &[[f64; 2]], distorted: &[[f64; 2]]) -> Result<OpenCvDistortion> {
    if undistorted.len() != distorted.len() || undistorted.len() < 5 {
        return Err(AnalysisError::invalid(
            "distortion fit",
            format!(
                "{} undistorted and {} distorted points: give the same number, at least 5",
                undistorted.len(),
                distorted.len()
            ),
        ));
    }
    if undistorted
        .iter()
        .chain(distorted)
        .any(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(AnalysisError::invalid(
            "distortion fit",
            "a point is not finite",
        ));
    }
    let n = undistorted.len();
    // Two equations per point; unknowns [k1, k2, p1, p2, k3]; right-hand side the displacement.
    let mut a = DMatrix::<f64>::zeros(2 * n, 5);
    let mut b = DVector::<f64>::zeros(2 * n);
    for (i, (u, d)) in undistorted.iter().zip(distorted).enumerate() {
        let [x, y] = *u;
        let r2 = x * x + y * y;
        let (r4, r6) = (r2 * r2, r2 * r2 * r2);
        let row = [x * r2, x * r4, 2.0 * x * y, r2 + 2.0 * x * x, x * r6];
        for (k, v) in row.iter().enumerate() {
            a[(2 * i, k)] = *v;
        }
        b[2 * i] = d[0] - x;
        let row = [y * r2, y * r4, r2 + 2.0 * y * y, 2.0 * x * y, y * r6];
        for (k, v) in row.iter().enumerate() {
            a[(2 * i + 1, k)] = *v;
        }
        b[2 * i + 1] = d[1] - y;
    }
    let c = crate::nnls::lstsq(&a, &b)?;
    Ok(OpenCvDistortion {
        k1: c[0],
        k2: c[1],
        p1: c[2],
        p2: c[3],
        k3: c[4],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Known coefficients are recovered from points they distort (the model is linear in them).
    #[test]
    fn known_coefficients_are_recovered() {
        let truth = OpenCvDistortion {
            k1: -0.21,
            k2: 0.043,
            p1: 1.2e-3,
            p2: -7e-4,
            k3: -0.004,
        };
        let mut u = Vec::new();
        for i in 0..9 {
            for j in 0..7 {
                u.push([-0.6 + 0.15 * i as f64, -0.45 + 0.15 * j as f64]);
            }
        }
        let d: Vec<[f64; 2]> = u.iter().map(|p| truth.apply(*p)).collect();
        let fit = fit_opencv(&u, &d).unwrap();
        for (a, b) in fit.coefficients().iter().zip(truth.coefficients()) {
            assert!((a - b).abs() < 1e-9, "{fit:?} against {truth:?}");
        }
        assert!(fit_opencv(&u[..4], &d[..4]).is_err());
    }
}
