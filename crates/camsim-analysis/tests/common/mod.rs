//! Shared test helpers: an independent least-squares QE matrix (nalgebra SVD), an accurate erf, analytic slanted-edge rendering, and a simple
//! Poisson + Gaussian frame generator keyed by camsim_core::rng::keyed.
#![allow(dead_code)]

use camsim_analysis::Plane;

/// Complementary error function, Numerical Recipes (Press et al. 2007, sec. 6.2) Chebyshev fit,
/// fractional error below 1.2e-7 everywhere.
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let ans = t
        * (-z * z - 1.26551223
            + t * (1.00002368
                + t * (0.37409196
                    + t * (0.09678418
                        + t * (-0.18628806
                            + t * (0.27886807
                                + t * (-1.13520398
                                    + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277)))))))))
            .exp();
    if x >= 0.0 {
        ans
    } else {
        2.0 - ans
    }
}

/// Standard normal CDF.
pub fn phi(t: f64) -> f64 {
    0.5 * erfc(-t / std::f64::consts::SQRT_2)
}

/// 10-point Gauss-Legendre nodes and weights on [-1, 1] (Abramowitz & Stegun 25.4.30).
const GL_X: [f64; 5] = [
    0.1488743389816312,
    0.4333953941292472,
    0.6794095682990244,
    0.8650633666889845,
    0.9739065285171717,
];
const GL_W: [f64; 5] = [
    0.2955242247147529,
    0.2692667193099963,
    0.219_086_362_515_982,
    0.1494513491505806,
    0.0666713443086881,
];

fn gl_nodes() -> Vec<(f64, f64)> {
    let mut v = vec![];
    for i in 0..5 {
        v.push((0.5 * GL_X[i], 0.5 * GL_W[i]));
        v.push((-0.5 * GL_X[i], 0.5 * GL_W[i]));
    }
    v
}

/// A straight edge through (x0, y0), at `angle_deg` clockwise from the vertical, dark `lo` on the
/// left and bright `hi` on the right (swap them for the other polarity), blurred by a Gaussian of
/// `sigma_px`. `area` = true integrates over each pixel's square aperture (10 x 10 Gauss-Legendre:
/// exact to ~1e-7 for sigma >= 0.4 px); false samples the pixel centre.
pub fn slanted_edge(
    rows: usize,
    cols: usize,
    angle_deg: f64,
    sigma_px: f64,
    lo: f64,
    hi: f64,
    area: bool,
) -> Plane {
    let th = angle_deg.to_radians();
    let (c, s) = (th.cos(), th.sin());
    let (x0, y0) = (cols as f64 / 2.0 + 0.3, rows as f64 / 2.0);
    let nodes = if area { gl_nodes() } else { vec![(0.0, 1.0)] };
    Plane::from_fn(rows, cols, |r, col| {
        let mut acc = 0.0;
        for (u, wu) in &nodes {
            for (v, wv) in &nodes {
                let x = col as f64 + 0.5 + u;
                let y = r as f64 + 0.5 + v;
                // Signed distance along the normal (cos, -sin): an edge rotated clockwise.
                let d = (x - x0) * c - (y - y0) * s;
                acc += wu * wv * phi(d / sigma_px);
            }
        }
        (lo + (hi - lo) * acc) as f32
    })
    .unwrap()
}

/// sin(pi x) / (pi x).
pub fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        1.0
    } else {
        (std::f64::consts::PI * x).sin() / (std::f64::consts::PI * x)
    }
}

/// MTF of a Gaussian blur: exp(-2 pi^2 sigma^2 f^2).
pub fn gauss_mtf(sigma_px: f64, f: f64) -> f64 {
    (-2.0 * std::f64::consts::PI.powi(2) * sigma_px * sigma_px * f * f).exp()
}

/// M (`target = source M`) by least squares over the wavelength samples, per output channel,
/// with nalgebra's SVD (not the solver under test); and the relative RMS residual per channel.
pub fn qe_level_m(source: &[Vec<f64>; 3], target: &[Vec<f64>; 3]) -> ([[f64; 3]; 3], [f64; 3]) {
    let n = source[0].len();
    let a = nalgebra::DMatrix::from_fn(n, 3, |r, i| source[i][r]);
    let svd = a.clone().svd(true, true);
    let mut m = [[0.0; 3]; 3];
    let mut rel = [0.0; 3];
    for j in 0..3 {
        let b = nalgebra::DVector::from_column_slice(&target[j]);
        let x = svd.solve(&b, 1e-12).unwrap();
        for i in 0..3 {
            m[i][j] = x[i];
        }
        rel[j] = (&a * &x - &b).norm() / b.norm();
    }
    (m, rel)
}
