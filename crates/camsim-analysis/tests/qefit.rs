//! QE correction matrix fit.
//!
//! 1. Recovery: "measurements" made from predictions with a known M (plus 0.3 % noise) give back
//!    M within 0.01 per entry, for each form (least squares is unbiased; the noise-induced
//!    scatter on 72 patches is ~1e-3).
//! 2. The paper: measurements computed with the paper's corrected Pixel 4a QE (isetcornellbox
//!    p4aCorrected) and predictions from the published IMX363 QE (filter x IR cut), 24 Ohta
//!    ColorChecker patches under CIE D65, A and F11 (a light box's daylight, incandescent and
//!    TL84-like lamps): the fitted non-negative lower form is close to the paper's printed M.
//!    The published QE in shared/data comes from a later ISETCam file than the paper used
//!    (published x paper M differs from p4aCorrected by 15-100 % at some wavelengths), so the
//!    agreement is to about 0.16 per entry (measured: a 0.564, b 0, c 0.686, d 0.203, e 0.718 vs
//!    the paper's 0.532, 0.06, 0.70, 0.36, 0.84). Independent check: p4aCorrected is an exact
//!    linear transform of this published QE, so the unconstrained fit leaves no residual.

use camsim_analysis::qefit::{apply_matrix, fit_qe_matrix, predict_rgb, MatrixForm, PAPER_M};
use camsim_core::rng::{keyed, stage};
use camsim_core::{tables, WavelengthGrid};
use rand_distr::{Distribution, Normal};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");

/// Read a CSV of wavelength_nm and columns, skipping '#' comments and the header; returns the
/// named columns sampled on the 400-700 nm, 10 nm grid.
fn read_qe(path: &str, cols: &[&str]) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut lines = text.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty());
    let header: Vec<&str> = lines.next().unwrap().split(',').map(|s| s.trim()).collect();
    let idx: Vec<usize> = cols.iter().map(|c| header.iter().position(|h| h == c).unwrap()).collect();
    let rows: Vec<Vec<f64>> = lines.map(|l| l.split(',').map(|v| v.trim().parse::<f64>().unwrap()).collect()).collect();
    let grid = WavelengthGrid::default();
    idx.iter()
        .map(|i| {
            (0..grid.len())
                .map(|b| {
                    let w = grid.wavelength_nm(b);
                    rows.iter().find(|r| (r[0] - w).abs() < 1e-6).map(|r| r[*i]).unwrap()
                })
                .collect()
        })
        .collect()
}

fn published_qe() -> [Vec<f64>; 3] {
    let v = read_qe(&format!("{DATA}/imx363_qe.csv"), &["r", "g", "b", "ir_filter"]);
    let eff = |c: usize| v[c].iter().zip(&v[3]).map(|(a, b)| a * b).collect::<Vec<f64>>();
    [eff(0), eff(1), eff(2)]
}

fn corrected_qe() -> [Vec<f64>; 3] {
    let v = read_qe(&format!("{DATA}/isetcornellbox/p4aCorrected.csv"), &["r", "g", "b"]);
    [v[0].clone(), v[1].clone(), v[2].clone()]
}

/// 24 Ohta patches x 3 lights, radiance = reflectance x relative SPD (arbitrary scale).
fn radiances() -> Vec<Vec<f64>> {
    let grid = WavelengthGrid::default();
    let patches = tables::macbeth_reflectances();
    let mut out = vec![];
    for light in ["D65", "A", "F11"] {
        let spd = tables::illuminant(light).unwrap();
        for p in &patches {
            out.push(p.product_on(&spd, &grid).iter().map(|v| v * 1e-3).collect());
        }
    }
    out
}

#[test]
fn known_matrices_are_recovered_for_every_form() {
    let grid = WavelengthGrid::default();
    let pred = predict_rgb(&published_qe(), &grid, &radiances(), 1.0).unwrap();
    let cases = [
        (MatrixForm::Unconstrained, [[0.9, 0.05, -0.02], [0.1, 0.8, 0.05], [0.0, 0.3, 0.85]]),
        (MatrixForm::Diagonal, [[0.55, 0.0, 0.0], [0.0, 0.72, 0.0], [0.0, 0.0, 0.81]]),
        (MatrixForm::PaperLowerNonNegative, PAPER_M),
    ];
    let noise = Normal::new(0.0, 0.003).unwrap();
    for (form, m) in cases {
        let exact = apply_matrix(&pred, &m);
        let measured: Vec<[f64; 3]> = exact
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let mut rng = keyed(5, stage::ANALYSIS, 0, i as u64);
                v.map(|x| x * (1.0 + noise.sample(&mut rng)))
            })
            .collect();
        let fit = fit_qe_matrix(&measured, &pred, form).unwrap();
        let worst = (0..9).map(|k| (fit.m[k / 3][k % 3] - m[k / 3][k % 3]).abs()).fold(0.0, f64::max);
        println!("{form:?}: worst entry error {worst:.5}, relative RMS before {:.4} after {:.4}", fit.relative_rms_before, fit.relative_rms_after);
        assert!(worst < 0.01, "{form:?}: {:?}", fit.m);
        // Entries outside the form stay exactly zero.
        for i in 0..3 {
            for j in 0..3 {
                if !form.mask()[i][j] {
                    assert_eq!(fit.m[i][j], 0.0);
                }
            }
        }
        assert!(fit.relative_rms_after < 0.01 && fit.relative_rms_after < fit.relative_rms_before);
        assert_eq!(fit.residuals_after.len(), 72);
    }
}

#[test]
fn fitted_matrix_for_published_qe_against_pixel4a_is_close_to_the_paper() {
    let grid = WavelengthGrid::default();
    let rad = radiances();
    let measured = predict_rgb(&corrected_qe(), &grid, &rad, 1.0).unwrap();
    let pred = predict_rgb(&published_qe(), &grid, &rad, 1.0).unwrap();
    for form in [MatrixForm::Unconstrained, MatrixForm::Diagonal, MatrixForm::PaperLowerNonNegative] {
        let fit = fit_qe_matrix(&measured, &pred, form).unwrap();
        println!(
            "{form:?}: M = [{:.3} {:.3} {:.3}; {:.3} {:.3} {:.3}; {:.3} {:.3} {:.3}], relative RMS {:.4} -> {:.4}",
            fit.m[0][0], fit.m[0][1], fit.m[0][2], fit.m[1][0], fit.m[1][1], fit.m[1][2], fit.m[2][0], fit.m[2][1], fit.m[2][2],
            fit.relative_rms_before, fit.relative_rms_after
        );
        match form {
            MatrixForm::PaperLowerNonNegative => {
                for i in 0..3 {
                    for j in 0..3 {
                        assert!((fit.m[i][j] - PAPER_M[i][j]).abs() < 0.2, "M[{i}][{j}] = {:.3}, paper {}", fit.m[i][j], PAPER_M[i][j]);
                    }
                }
                assert!(fit.relative_rms_after < 0.1 * fit.relative_rms_before);
            }
            MatrixForm::Unconstrained => assert!(fit.relative_rms_after < 1e-3),
            MatrixForm::Diagonal => assert!(fit.relative_rms_after < 0.2 * fit.relative_rms_before),
        }
    }
}
