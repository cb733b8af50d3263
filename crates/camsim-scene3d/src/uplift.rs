//! RGB -> spectrum uplift for reflectances: the sigmoid-polynomial model of
//! W. Jakob and J. Hanika, "A Low-Dimensional Function Space for Efficient Spectral Upsampling",
//! Computer Graphics Forum 38(2), 2019 (the method pbrt-v4 uses for `rgb` reflectances).
//!
//! A reflectance is `s(lambda) = S(c0 t^2 + c1 t + c2)` with `S(x) = 1/2 + x / (2 sqrt(1 + x^2))`,
//! a sigmoid with values strictly inside (0, 1) (so every uplifted reflectance conserves energy),
//! and `t = (lambda - 360 nm) / (830 nm - 360 nm)` (a normalised wavelength; the paper uses
//! lambda in nm, which is the same polynomial with rescaled coefficients). The three coefficients
//! are found by Gauss-Newton so that the spectrum's colour under the colour space's white
//! (CIE D65 for linear sRGB) matches the target in CIELAB (the paper's objective, CIE76 Delta E).
//!
//! Two entry points:
//! - [`rgb_to_reflectance_spectrum`]: a full fit for one RGB value (constant reflectances).
//! - [`rgb_to_reflectance`] / [`rgb_to_coefficients`]: a lookup in a coefficient table built once
//!   at first use (as the paper and pbrt-v4 do: for each largest component, a grid over the two
//!   ratios and the brightness, filled by continuation from a mid-grey start), trilinearly
//!   interpolated. This is what an image texture uses per lookup.
//!
//! Greys (r = g = b) map exactly to the constant spectrum of that value (pbrt-v4 does the same).
//! RGB components are clamped to [0, 1] (a reflectance cannot exceed 1; pbrt-v4 rejects
//! `rgb reflectance` components above 1 at parse time, see `camsim_pbrt`).

use camsim_core::colorimetry::{linear_srgb_to_xyz, xyz_to_linear_srgb};
use camsim_core::{tables, Spectrum, WavelengthGrid};
use rayon::prelude::*;
use std::sync::OnceLock;

/// Lower end of the fitting range, nm (the CIE 1931 tables' range).
pub const LAMBDA_MIN_NM: f64 = 360.0;
/// Upper end of the fitting range, nm.
pub const LAMBDA_MAX_NM: f64 = 830.0;
/// Resolution of the coefficient table per axis.
pub const TABLE_RES: usize = 24;

/// Sigmoid-polynomial coefficients (Jakob & Hanika 2019) in the normalised wavelength `t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SigmoidPolynomial {
    /// Quadratic, linear and constant coefficients of the polynomial in `t` (dimensionless).
    pub c: [f64; 3],
}

impl SigmoidPolynomial {
    /// Reflectance (fraction, in [0, 1]) at `wavelength_nm`.
    #[inline]
    pub fn eval(&self, wavelength_nm: f64) -> f64 {
        let t = (wavelength_nm - LAMBDA_MIN_NM) / (LAMBDA_MAX_NM - LAMBDA_MIN_NM);
        sigmoid(self.c[0] * t * t + self.c[1] * t + self.c[2])
    }

    /// The constant spectrum `v` (0 <= v <= 1) as a sigmoid polynomial (pbrt-v4's grey case).
    pub fn constant(v: f64) -> Self {
        let v = v.clamp(0.0, 1.0);
        let c2 = if v <= 0.0 {
            f64::NEG_INFINITY
        } else if v >= 1.0 {
            f64::INFINITY
        } else {
            (v - 0.5) / (v * (1.0 - v)).sqrt()
        };
        SigmoidPolynomial { c: [0.0, 0.0, c2] }
    }
}

/// `S(x) = 1/2 + x / (2 sqrt(1 + x^2))` (Jakob & Hanika 2019 eq. 3); handles +-infinity.
#[inline]
pub fn sigmoid(x: f64) -> f64 {
    if x.is_infinite() {
        return if x > 0.0 { 1.0 } else { 0.0 };
    }
    if x.is_nan() {
        return 0.0;
    }
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

/// Tabulated colour-matching weights for the fit: `x_bar D65 dl / sum(y_bar D65 dl)` at 5 nm.
struct FitData {
    wavelengths_nm: Vec<f64>,
    t: Vec<f64>,
    w: [Vec<f64>; 3],
    white_xyz: [f64; 3],
}

fn fit_data() -> &'static FitData {
    static DATA: OnceLock<FitData> = OnceLock::new();
    DATA.get_or_init(|| {
        let [x, y, z] = tables::cie1931_xyz_cmfs();
        // CIE D65 relative SPD (the white of linear sRGB, IEC 61966-2-1).
        let d65 = tables::illuminant("D65").expect("D65 is a built-in table");
        let n = ((LAMBDA_MAX_NM - LAMBDA_MIN_NM) / 5.0).round() as usize + 1;
        let wavelengths_nm: Vec<f64> = (0..n).map(|i| LAMBDA_MIN_NM + 5.0 * i as f64).collect();
        let t = wavelengths_nm
            .iter()
            .map(|l| (l - LAMBDA_MIN_NM) / (LAMBDA_MAX_NM - LAMBDA_MIN_NM))
            .collect();
        let mut w = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut y_sum = 0.0;
        for (i, &l) in wavelengths_nm.iter().enumerate() {
            let e = d65.eval(l);
            w[0][i] = x.eval(l) * e;
            w[1][i] = y.eval(l) * e;
            w[2][i] = z.eval(l) * e;
            y_sum += w[1][i];
        }
        for c in w.iter_mut() {
            c.iter_mut().for_each(|v| *v /= y_sum);
        }
        let white_xyz = [w[0].iter().sum(), w[1].iter().sum(), w[2].iter().sum()];
        FitData {
            wavelengths_nm,
            t,
            w,
            white_xyz,
        }
    })
}

/// CIE 1976 L*a*b* of `xyz` relative to `white` (CIE 015:2018 eq. 8.1-8.3).
fn xyz_to_lab(xyz: [f64; 3], white: [f64; 3]) -> [f64; 3] {
    let f = |t: f64| {
        let d = 6.0 / 29.0;
        if t > d * d * d {
            t.cbrt()
        } else {
            t / (3.0 * d * d) + 4.0 / 29.0
        }
    };
    let fx = f(xyz[0] / white[0]);
    let fy = f(xyz[1] / white[1]);
    let fz = f(xyz[2] / white[2]);
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

fn spectrum_xyz(c: &[f64; 3], d: &FitData) -> [f64; 3] {
    let mut xyz = [0.0; 3];
    for (i, &t) in d.t.iter().enumerate() {
        let s = sigmoid(c[0] * t * t + c[1] * t + c[2]);
        xyz[0] += s * d.w[0][i];
        xyz[1] += s * d.w[1][i];
        xyz[2] += s * d.w[2][i];
    }
    xyz
}

fn residual(c: &[f64; 3], target_lab: &[f64; 3], d: &FitData) -> [f64; 3] {
    let lab = xyz_to_lab(spectrum_xyz(c, d), d.white_xyz);
    [
        lab[0] - target_lab[0],
        lab[1] - target_lab[1],
        lab[2] - target_lab[2],
    ]
}

fn norm(r: &[f64; 3]) -> f64 {
    (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt()
}

/// Solve the 3x3 system `a x = b` (Gaussian elimination with partial pivoting).
fn solve3(mut a: [[f64; 3]; 3], mut b: [f64; 3]) -> Option<[f64; 3]> {
    for col in 0..3 {
        let piv = (col..3).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() < 1e-15 {
            return None;
        }
        a.swap(col, piv);
        b.swap(col, piv);
        for row in col + 1..3 {
            let f = a[row][col] / a[col][col];
            for k in col..3 {
                a[row][k] -= f * a[col][k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 3];
    for row in (0..3).rev() {
        let s: f64 = (row + 1..3).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Gauss-Newton on the CIELAB residual from the start `c` (Jakob & Hanika 2019 section 4),
/// with step halving when a step does not reduce the residual. Returns the coefficients and the
/// final residual (Delta E*ab).
fn gauss_newton(rgb: [f64; 3], mut c: [f64; 3], iterations: usize) -> ([f64; 3], f64) {
    let d = fit_data();
    let target_lab = xyz_to_lab(linear_srgb_to_xyz(rgb), d.white_xyz);
    let mut r = residual(&c, &target_lab, d);
    let mut rn = norm(&r);
    for _ in 0..iterations {
        if rn < 1e-6 {
            break;
        }
        // Jacobian by central differences.
        let mut jac = [[0.0; 3]; 3];
        for k in 0..3 {
            let h = 1e-4 * c[k].abs().max(1.0);
            let mut cp = c;
            let mut cm = c;
            cp[k] += h;
            cm[k] -= h;
            let rp = residual(&cp, &target_lab, d);
            let rm = residual(&cm, &target_lab, d);
            for i in 0..3 {
                jac[i][k] = (rp[i] - rm[i]) / (2.0 * h);
            }
        }
        let Some(step) = solve3(jac, [-r[0], -r[1], -r[2]]) else {
            break;
        };
        let mut scale = 1.0;
        let mut improved = false;
        for _ in 0..12 {
            let cn = [
                c[0] + scale * step[0],
                c[1] + scale * step[1],
                c[2] + scale * step[2],
            ];
            let rnew = residual(&cn, &target_lab, d);
            let nn = norm(&rnew);
            if nn.is_finite() && nn < rn {
                c = cn;
                r = rnew;
                rn = nn;
                improved = true;
                break;
            }
            scale *= 0.5;
        }
        if !improved {
            break;
        }
        // Keep the polynomial bounded (Jakob & Hanika clamp the coefficient magnitude).
        let m = c.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if m > 400.0 {
            let k = 400.0 / m;
            c.iter_mut().for_each(|v| *v *= k);
            r = residual(&c, &target_lab, d);
            rn = norm(&r);
        }
    }
    (c, rn)
}

fn clamp_rgb(rgb: [f32; 3]) -> [f64; 3] {
    let f = |v: f32| {
        if v.is_nan() {
            0.0
        } else {
            (v as f64).clamp(0.0, 1.0)
        }
    };
    [f(rgb[0]), f(rgb[1]), f(rgb[2])]
}

/// Brightness scale of the table's third axis: `smoothstep(smoothstep(k / (res - 1)))`
/// (Jakob & Hanika 2019 section 4: samples concentrated near black and near full reflectance).
fn z_scale(k: usize) -> f64 {
    let smooth = |x: f64| x * x * (3.0 - 2.0 * x);
    smooth(smooth(k as f64 / (TABLE_RES - 1) as f64))
}

struct Table {
    z: Vec<f64>,
    /// `[max component][z][y][x] -> c` flattened.
    coeffs: Vec<[f32; 3]>,
}

fn table() -> &'static Table {
    static TABLE: OnceLock<Table> = OnceLock::new();
    TABLE.get_or_init(build_table)
}

fn build_table() -> Table {
    let n = TABLE_RES;
    let z: Vec<f64> = (0..n).map(z_scale).collect();
    let columns: Vec<(usize, usize, usize)> = (0..3)
        .flat_map(|l| (0..n).flat_map(move |j| (0..n).map(move |i| (l, j, i))))
        .collect();
    let results: Vec<Vec<[f32; 3]>> = columns
        .par_iter()
        .map(|&(l, j, i)| {
            let x = i as f64 / (n - 1) as f64;
            let y = j as f64 / (n - 1) as f64;
            let mut out = vec![[0.0f32; 3]; n];
            let rgb_at = |k: usize| {
                let b = z[k];
                let mut rgb = [0.0; 3];
                rgb[l] = b;
                rgb[(l + 1) % 3] = x * b;
                rgb[(l + 2) % 3] = y * b;
                rgb
            };
            let start = n / 5;
            let mut c = [0.0; 3];
            for k in start..n {
                c = gauss_newton(rgb_at(k), c, 30).0;
                out[k] = [c[0] as f32, c[1] as f32, c[2] as f32];
            }
            c = [
                out[start][0] as f64,
                out[start][1] as f64,
                out[start][2] as f64,
            ];
            for k in (0..start).rev() {
                c = gauss_newton(rgb_at(k), c, 30).0;
                out[k] = [c[0] as f32, c[1] as f32, c[2] as f32];
            }
            out
        })
        .collect();
    let mut coeffs = vec![[0.0f32; 3]; 3 * n * n * n];
    for (&(l, j, i), col) in columns.iter().zip(&results) {
        for (k, c) in col.iter().enumerate() {
            coeffs[((l * n + k) * n + j) * n + i] = *c;
        }
    }
    Table { z, coeffs }
}

/// Build the coefficient table now (it is otherwise built at the first texture lookup).
pub fn warm_up() {
    let _ = table();
}

/// Coefficients for a linear-sRGB reflectance by table lookup (trilinear interpolation).
/// Components are clamped to [0, 1].
pub fn rgb_to_coefficients(rgb: [f32; 3]) -> SigmoidPolynomial {
    let rgb = clamp_rgb(rgb);
    if rgb[0] == rgb[1] && rgb[1] == rgb[2] {
        return SigmoidPolynomial::constant(rgb[0]);
    }
    let t = table();
    let n = TABLE_RES;
    // Largest component picks the block (ties resolved toward the first).
    let l = if rgb[0] >= rgb[1] && rgb[0] >= rgb[2] {
        0
    } else if rgb[1] >= rgb[2] {
        1
    } else {
        2
    };
    let zv = rgb[l];
    let xv = rgb[(l + 1) % 3] / zv * (n - 1) as f64;
    let yv = rgb[(l + 2) % 3] / zv * (n - 1) as f64;
    let xi = (xv.floor() as usize).min(n - 2);
    let yi = (yv.floor() as usize).min(n - 2);
    let zi =
        t.z.partition_point(|v| *v <= zv)
            .saturating_sub(1)
            .min(n - 2);
    let fx = xv - xi as f64;
    let fy = yv - yi as f64;
    let fz = ((zv - t.z[zi]) / (t.z[zi + 1] - t.z[zi])).clamp(0.0, 1.0);
    let at = |k: usize, j: usize, i: usize| t.coeffs[((l * n + k) * n + j) * n + i];
    let mut c = [0.0f64; 3];
    for (dk, wk) in [(0, 1.0 - fz), (1, fz)] {
        for (dj, wj) in [(0, 1.0 - fy), (1, fy)] {
            for (di, wi) in [(0, 1.0 - fx), (1, fx)] {
                let w = wk * wj * wi;
                if w == 0.0 {
                    continue;
                }
                let v = at(zi + dk, yi + dj, xi + di);
                for m in 0..3 {
                    c[m] += w * v[m] as f64;
                }
            }
        }
    }
    SigmoidPolynomial { c }
}

/// Reflectance (fraction, 0..1) of the uplifted linear-sRGB colour `rgb` at `wavelength_nm`
/// (table lookup; see the module docs). Never exceeds 1.
pub fn rgb_to_reflectance(rgb: [f32; 3], wavelength_nm: f64) -> f64 {
    rgb_to_coefficients(rgb).eval(wavelength_nm)
}

/// Coefficients fitted for this one colour (table start refined by Gauss-Newton), and the
/// remaining colour difference Delta E*ab under D65.
pub fn fit_coefficients(rgb: [f32; 3]) -> (SigmoidPolynomial, f64) {
    let rgbd = clamp_rgb(rgb);
    if rgbd[0] == rgbd[1] && rgbd[1] == rgbd[2] {
        return (SigmoidPolynomial::constant(rgbd[0]), 0.0);
    }
    let start = rgb_to_coefficients(rgb).c;
    let (c, err) = gauss_newton(rgbd, start, 50);
    (SigmoidPolynomial { c }, err)
}

/// The uplifted reflectance of linear-sRGB `rgb` sampled on `grid` (a full fit; values in [0, 1]).
pub fn rgb_to_reflectance_spectrum(rgb: [f32; 3], grid: &WavelengthGrid) -> Spectrum {
    let (p, _) = fit_coefficients(rgb);
    Spectrum::on_grid(
        grid,
        (0..grid.len())
            .map(|i| p.eval(grid.wavelength_nm(i)))
            .collect(),
    )
}

/// The uplifted reflectance of `rgb` as a spectrum on the fitting range (360-830 nm every 5 nm),
/// for use before the render grid is known.
pub fn rgb_to_reflectance_full(rgb: [f32; 3]) -> Spectrum {
    let (p, _) = fit_coefficients(rgb);
    let d = fit_data();
    Spectrum::from_pairs(
        &d.wavelengths_nm
            .iter()
            .map(|&l| (l, p.eval(l)))
            .collect::<Vec<_>>(),
    )
}

/// Linear sRGB of a reflectance spectrum under D65 (white = 1), the forward model of the fit.
pub fn reflectance_to_rgb(reflectance: &Spectrum) -> [f64; 3] {
    let d = fit_data();
    let mut xyz = [0.0; 3];
    for (i, &l) in d.wavelengths_nm.iter().enumerate() {
        let s = reflectance.eval(l);
        for (c, v) in xyz.iter_mut().enumerate() {
            *v += s * d.w[c][i];
        }
    }
    xyz_to_linear_srgb(xyz)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn greys_are_exact_constants() {
        for v in [0.0f32, 0.18, 0.5, 0.9, 1.0] {
            for l in [380.0, 555.0, 720.0] {
                assert!((rgb_to_reflectance([v, v, v], l) - v as f64).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn fitted_colours_reproduce_their_rgb_and_stay_in_0_1() {
        let g = WavelengthGrid::new(360.0, 830.0, 5.0).unwrap();
        for rgb in [
            [0.8f32, 0.1, 0.1],
            [0.1, 0.6, 0.2],
            [0.2, 0.3, 0.7],
            [0.9, 0.8, 0.2],
            [0.05, 0.05, 0.06],
        ] {
            let s = rgb_to_reflectance_spectrum(rgb, &g);
            assert!(s.values.iter().all(|v| (0.0..=1.0).contains(v)));
            let back = reflectance_to_rgb(&s);
            for c in 0..3 {
                assert!(
                    (back[c] - rgb[c] as f64).abs() < 5e-3,
                    "{rgb:?} -> {back:?}"
                );
            }
        }
    }

    #[test]
    fn table_lookup_reproduces_rgb_and_conserves_energy() {
        let t0 = std::time::Instant::now();
        warm_up();
        let build_s = t0.elapsed().as_secs_f64();
        let mut worst = 0.0f64;
        let levels = [0.02f32, 0.1, 0.3, 0.55, 0.8, 0.97];
        for &r in &levels {
            for &g in &levels {
                for &b in &levels {
                    let p = rgb_to_coefficients([r, g, b]);
                    let s = Spectrum::from_pairs(
                        &(0..95)
                            .map(|i| 360.0 + 5.0 * i as f64)
                            .map(|l| (l, p.eval(l)))
                            .collect::<Vec<_>>(),
                    );
                    assert!(s.values.iter().all(|v| (0.0..=1.0).contains(v)));
                    let back = reflectance_to_rgb(&s);
                    for (c, t) in back.iter().zip([r, g, b]) {
                        worst = worst.max((c - t as f64).abs());
                    }
                }
            }
        }
        eprintln!("uplift table: built in {build_s:.2} s, worst RGB round-trip error {worst:.4}");
        assert!(worst < 0.02, "{worst}");
    }
}
