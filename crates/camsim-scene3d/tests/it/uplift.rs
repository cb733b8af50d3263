//! The sRGB -> spectrum table (Jakob & Hanika 2019, computed at build time as pbrt-v4 computes
//! its table) against independent values:
//! * round trip: every looked-up reflectance, integrated with the CIE 1931 observer and D65 by a
//!   1 nm trapezoid rule (not the table's Simpson 3/8 quadrature) and turned into linear sRGB
//!   with camsim-core's matrix (not the optimiser's), gives back its colour;
//! * spot values: at table nodes, a separate solver (damped Newton on the XYZ residual from a
//!   flat start, 1 nm trapezoid) finds the same spectrum at 400..700 nm;
//! * the compiled table is what `rgb2spec::column` computes (the build step is deterministic).

use camsim_core::colorimetry::xyz_to_linear_srgb;
use camsim_core::tables;
use camsim_scene3d::rgb2spec::{self, sigmoid};
use camsim_scene3d::uplift::{
    rgb_to_coefficients, table_coefficients, table_node_rgb, SigmoidPolynomial, LAMBDA_MAX_NM,
    LAMBDA_MIN_NM, TABLE_RES,
};

/// CIE 1931 x-bar D65, y-bar D65, z-bar D65 every 1 nm over 360-830 nm with trapezoid weights,
/// normalised so the white has Y = 1.
fn trapezoid_weights() -> Vec<(f64, [f64; 3])> {
    let [x, y, z] = tables::cie1931_xyz_cmfs();
    let d65 = tables::illuminant("D65").unwrap();
    let n = (LAMBDA_MAX_NM - LAMBDA_MIN_NM) as usize;
    let mut w: Vec<(f64, [f64; 3])> = (0..=n)
        .map(|i| {
            let l = LAMBDA_MIN_NM + i as f64;
            let end = if i == 0 || i == n { 0.5 } else { 1.0 };
            let e = d65.eval(l) * end;
            (l, [x.eval(l) * e, y.eval(l) * e, z.eval(l) * e])
        })
        .collect();
    let yw: f64 = w.iter().map(|(_, v)| v[1]).sum();
    for (_, v) in w.iter_mut() {
        v.iter_mut().for_each(|c| *c /= yw);
    }
    w
}

fn xyz_of(p: &SigmoidPolynomial, w: &[(f64, [f64; 3])]) -> [f64; 3] {
    let mut xyz = [0.0; 3];
    for (l, v) in w {
        let s = p.eval(*l);
        for k in 0..3 {
            xyz[k] += s * v[k];
        }
    }
    xyz
}

#[test]
fn lookups_reproduce_their_srgb_colour() {
    let w = trapezoid_weights();
    let levels = [0.02f32, 0.07, 0.15, 0.3, 0.5, 0.7, 0.85, 0.97];
    let (mut worst, mut worst_at) = (0.0f64, [0f32; 3]);
    for &r in &levels {
        for &g in &levels {
            for &b in &levels {
                let rgb = [r, g, b];
                let p = rgb_to_coefficients(rgb);
                for l in [360.0, 400.0, 550.0, 700.0, 830.0] {
                    let s = p.eval(l);
                    assert!((0.0..=1.0).contains(&s), "{rgb:?} at {l} nm: {s}");
                }
                let back = xyz_to_linear_srgb(xyz_of(&p, &w));
                for k in 0..3 {
                    let e = (back[k] - rgb[k] as f64).abs();
                    if e > worst {
                        (worst, worst_at) = (e, rgb);
                    }
                }
            }
        }
    }
    eprintln!("uplift round trip: worst linear-sRGB error {worst:.5} at {worst_at:?}");
    assert!(worst < 0.004, "{worst} at {worst_at:?}");
}

/// Damped Newton on `M^-1 rgb - XYZ(c)` (1 nm trapezoid, numerical Jacobian) from c = 0 along a
/// brightness path from grey (the colour blended toward its mean in 20 steps), so each step
/// starts near its solution.
fn independent_solve(rgb: [f64; 3], w: &[(f64, [f64; 3])]) -> SigmoidPolynomial {
    let target = camsim_core::colorimetry::linear_srgb_to_xyz(rgb);
    let grey = (rgb[0] + rgb[1] + rgb[2]) / 3.0;
    let grey_xyz = camsim_core::colorimetry::linear_srgb_to_xyz([grey; 3]);
    let mut c = SigmoidPolynomial::constant(grey).c;
    let f = |c: &[f64; 3], t: &[f64; 3]| {
        let x = xyz_of(&SigmoidPolynomial { c: *c }, w);
        [x[0] - t[0], x[1] - t[1], x[2] - t[2]]
    };
    for step in 1..=20 {
        let a = step as f64 / 20.0;
        let t: [f64; 3] = std::array::from_fn(|k| grey_xyz[k] + a * (target[k] - grey_xyz[k]));
        for _ in 0..50 {
            let r = f(&c, &t);
            let n0 = r.iter().map(|v| v * v).sum::<f64>().sqrt();
            if n0 < 1e-12 {
                break;
            }
            let mut j = [[0.0; 3]; 3];
            for m in 0..3 {
                let mut cp = c;
                cp[m] += 1e-6;
                let rp = f(&cp, &t);
                for k in 0..3 {
                    j[k][m] = (rp[k] - r[k]) / 1e-6;
                }
            }
            // Cramer's rule for j dx = -r.
            let det = |m: &[[f64; 3]; 3]| {
                m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                    - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                    + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
            };
            let d = det(&j);
            let dx: [f64; 3] = std::array::from_fn(|col| {
                let mut mm = j;
                for k in 0..3 {
                    mm[k][col] = -r[k];
                }
                det(&mm) / d
            });
            let mut s = 1.0;
            loop {
                let cn: [f64; 3] = std::array::from_fn(|k| c[k] + s * dx[k]);
                let rn = f(&cn, &t);
                if rn.iter().map(|v| v * v).sum::<f64>().sqrt() < n0 || s < 1e-4 {
                    c = cn;
                    break;
                }
                s *= 0.5;
            }
        }
    }
    SigmoidPolynomial { c }
}

#[test]
fn table_nodes_match_an_independent_solution() {
    let w = trapezoid_weights();
    let n = TABLE_RES;
    let mut worst = 0.0f64;
    // Nodes of each block, from dark to bright and from near-grey to saturated.
    for (l, k, j, i) in [
        (0, 20, 20, 40),
        (0, 40, 10, 30),
        (1, 30, 50, 20),
        (1, 45, 30, 5),
        (2, 35, 40, 50),
        (2, 50, 10, 20),
        (0, 55, 60, 15),
    ] {
        assert!(k < n && j < n && i < n);
        let rgb = table_node_rgb(l, k, j, i);
        let stored = table_coefficients(l, k, j, i).map(|v| v as f64);
        let table = SigmoidPolynomial { c: stored };
        let solved = independent_solve(rgb, &w);
        let mut line = String::new();
        for lambda in (400..=700).step_by(50) {
            let (a, b) = (table.eval(lambda as f64), solved.eval(lambda as f64));
            worst = worst.max((a - b).abs());
            line += &format!(" {lambda}: {a:.4}/{b:.4}");
        }
        eprintln!("node ({l}, {k}, {j}, {i}) rgb {rgb:.3?}: table/independent{line}");
    }
    eprintln!("largest reflectance difference {worst:.5}");
    assert!(worst < 2e-3, "{worst}");
}

#[test]
fn compiled_table_is_the_generator_output() {
    let mut d65: Vec<f64> = tables::cie::D65[12..].to_vec();
    d65.extend_from_slice(&rgb2spec::D65_785_830);
    let q = rgb2spec::Quadrature::new(&rgb2spec::ObserverTables {
        cmfs: [
            &tables::cie::CIE1931_X_BAR,
            &tables::cie::CIE1931_Y_BAR,
            &tables::cie::CIE1931_Z_BAR,
        ],
        illuminant: &d65,
    });
    for (l, j, i) in [(0, 7, 63), (1, 33, 2), (2, 63, 40)] {
        let col = rgb2spec::column(&q, TABLE_RES, l, j, i);
        for (k, c) in col.iter().enumerate() {
            assert_eq!(
                *c,
                table_coefficients(l, k, j, i),
                "node ({l}, {k}, {j}, {i})"
            );
        }
    }
    // Sanity of the sigmoid the table is read with.
    assert_eq!(sigmoid(0.0), 0.5);
}
