//! Non-negative least squares: minimise ||A x - b||_2 subject to x >= 0, by the active-set
//! algorithm of Lawson & Hanson ("Solving Least Squares Problems", 1974, ch. 23, algorithm NNLS).

use crate::error::{AnalysisError, Result};
use nalgebra::{DMatrix, DVector};

/// Unconstrained least squares on the columns `cols` of `a` (SVD solve, rank-tolerant).
fn ls_subset(a: &DMatrix<f64>, b: &DVector<f64>, cols: &[usize]) -> Result<DVector<f64>> {
    let sub = a.select_columns(cols.iter());
    let scale = sub.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
    let svd = sub.svd(true, true);
    svd.solve(b, 1e-13 * scale * (a.nrows().max(a.ncols()) as f64))
        .map_err(|e| AnalysisError::invalid("least squares", e.to_string()))
}

/// Least squares without constraints: argmin ||A x - b||.
pub fn lstsq(a: &DMatrix<f64>, b: &DVector<f64>) -> Result<DVector<f64>> {
    check(a, b)?;
    let cols: Vec<usize> = (0..a.ncols()).collect();
    ls_subset(a, b, &cols)
}

fn check(a: &DMatrix<f64>, b: &DVector<f64>) -> Result<()> {
    if a.nrows() != b.len() {
        return Err(AnalysisError::invalid(
            "least squares",
            format!("{} equations but {} right-hand values", a.nrows(), b.len()),
        ));
    }
    if a.ncols() == 0 || a.nrows() == 0 {
        return Err(AnalysisError::invalid(
            "least squares",
            "no unknowns or no equations",
        ));
    }
    if a.iter().chain(b.iter()).any(|v| !v.is_finite()) {
        return Err(AnalysisError::invalid(
            "least squares",
            "the data hold values that are not finite",
        ));
    }
    Ok(())
}

/// Lawson-Hanson NNLS: argmin ||A x - b|| with x >= 0.
pub fn nnls(a: &DMatrix<f64>, b: &DVector<f64>) -> Result<DVector<f64>> {
    check(a, b)?;
    let n = a.ncols();
    let mut x = DVector::<f64>::zeros(n);
    let mut passive = vec![false; n];
    let scale =
        a.iter().fold(0.0f64, |m, v| m.max(v.abs())) * b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let tol = 1e-12 * scale.max(1e-300) * a.nrows() as f64;
    let max_iter = 30 * n + 10;
    let mut iter = 0;
    loop {
        // Gradient of -1/2 ||A x - b||^2: w = A^T (b - A x).
        let w = a.transpose() * (b - a * &x);
        let cand = (0..n)
            .filter(|j| !passive[*j] && w[*j] > tol)
            .max_by(|i, j| w[*i].total_cmp(&w[*j]));
        let Some(t) = cand else { break };
        passive[t] = true;
        // Inner loop: keep the passive set feasible.
        loop {
            iter += 1;
            if iter > max_iter {
                return Err(AnalysisError::invalid(
                    "non-negative least squares",
                    "did not converge",
                ));
            }
            let p: Vec<usize> = (0..n).filter(|j| passive[*j]).collect();
            let sp = ls_subset(a, b, &p)?;
            let mut s = DVector::<f64>::zeros(n);
            for (k, j) in p.iter().enumerate() {
                s[*j] = sp[k];
            }
            if p.iter().all(|j| s[*j] > 0.0) {
                x = s;
                break;
            }
            // Step towards s until the first passive variable reaches zero.
            let mut alpha = f64::INFINITY;
            for j in &p {
                if s[*j] <= 0.0 {
                    alpha = alpha.min(x[*j] / (x[*j] - s[*j]));
                }
            }
            x += (s - &x) * alpha;
            for j in p {
                if x[j] <= 1e-15 * x.amax().max(1e-300) {
                    x[j] = 0.0;
                    passive[j] = false;
                }
            }
        }
    }
    Ok(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nnls_equals_least_squares_when_the_solution_is_positive() {
        let a = DMatrix::from_row_slice(4, 2, &[1.0, 0.0, 0.0, 1.0, 1.0, 1.0, 2.0, 1.0]);
        let x_true = DVector::from_vec(vec![0.7, 1.3]);
        let b = &a * &x_true;
        let x = nnls(&a, &b).unwrap();
        assert!((x - x_true).amax() < 1e-12);
    }

    #[test]
    fn nnls_satisfies_the_kkt_conditions_when_a_bound_is_active() {
        // Unconstrained solution has a negative component; NNLS must return x >= 0 with the
        // Karush-Kuhn-Tucker conditions: w = A^T(b - A x) <= 0 everywhere, w_j = 0 where x_j > 0.
        let a = DMatrix::from_row_slice(
            5,
            3,
            &[
                1.0, 0.9, 0.1, 0.5, 0.6, 0.3, 0.2, 0.1, 1.0, 0.9, 1.0, 0.2, 0.3, 0.2, 0.7,
            ],
        );
        let b = DVector::from_vec(vec![0.2, 0.1, 1.0, -0.1, 0.8]);
        let ls = lstsq(&a, &b).unwrap();
        assert!(
            ls.iter().any(|v| *v < 0.0),
            "test needs an active bound: {ls}"
        );
        let x = nnls(&a, &b).unwrap();
        let w = a.transpose() * (&b - &a * &x);
        for j in 0..3 {
            assert!(x[j] >= 0.0);
            assert!(w[j] <= 1e-10, "w {w}");
            if x[j] > 0.0 {
                assert!(w[j].abs() < 1e-10, "w {w}");
            }
        }
        assert!(nnls(&a, &DVector::from_vec(vec![1.0])).is_err());
    }
}
