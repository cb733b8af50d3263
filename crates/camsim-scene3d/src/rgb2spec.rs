//! The optimisation behind the sRGB -> spectrum coefficient table (Jakob and Hanika 2019, "A
//! Low-Dimensional Function Space for Efficient Spectral Upsampling", Computer Graphics Forum
//! 38(2), section 4), set up as pbrt-v4 sets up its table for the sRGB colour space (its build
//! runs the paper's optimiser at 64^3 per largest component), so that camsim's uplifted
//! reflectances match pbrt-v4's band for band:
//!
//! * observer: CIE 1931 2-degree colour-matching functions, 360-830 nm every 5 nm (CIE
//!   015:2018), linearly interpolated; illuminant: CIE D65 over the same range (CIE S 014-2 /
//!   ISO 11664-2, including 785-830 nm), scaled so the white has Y = 1;
//! * quadrature: each 5 nm interval split in three, composite Simpson 3/8 rule (283 nodes);
//! * objective: CIELAB difference (CIE 015:2018 eq. 8.1-8.3) between the target linear-sRGB
//!   colour and the reflectance's colour under D65, both relative to the D65 white of the
//!   quadrature; the spectrum's XYZ goes through linear sRGB and back with the 6-digit BT.709 /
//!   D65 matrices of the paper's optimiser;
//! * Gauss-Newton: Jacobian by central differences (step 1e-4), at most 15 steps, stopping once
//!   the squared residual before a step is below 1e-6; when the largest coefficient exceeds 200
//!   all three are scaled down to make it 200 (keeps the polynomial bounded);
//! * table: for each largest component `l` and the two ratios `x = i / (res - 1)`,
//!   `y = j / (res - 1)` of the other components to it, brightness nodes
//!   `b_k = smoothstep(smoothstep(k / (res - 1)))` (denser near black and white), solved from
//!   `k = res / 5` upward and again from there downward, each solve starting from the previous
//!   node's solution (the first of each sweep from zero).
//!
//! [`generate`] is deterministic (a pure function of its inputs, whatever the thread count) and
//! builds the 64^3 table in seconds on two cores in a release build; `build.rs` runs it at
//! build time (as pbrt-v4's CMake runs its optimiser), so the table is compiled in and
//! [`crate::uplift`] only looks it up.
//!
//! Coefficients are stored for the normalised wavelength `t = (lambda - 360) / 470`
//! (`s(lambda) = S(c0 t^2 + c1 t + c2)`); pbrt-v4 stores the same polynomial in nm.

/// First wavelength of the quadrature and of `t`, nm.
pub const LAMBDA_MIN_NM: f64 = 360.0;
/// Last wavelength, nm.
pub const LAMBDA_MAX_NM: f64 = 830.0;
/// Table resolution per axis (pbrt-v4's).
pub const RES: usize = 64;

/// Tabulated spectra in 5 nm steps from 360 to 830 nm (95 values each).
pub struct ObserverTables<'a> {
    /// CIE 1931 x-bar, y-bar, z-bar.
    pub cmfs: [&'a [f64]; 3],
    /// The colour space's white illuminant (any scale).
    pub illuminant: &'a [f64],
}

/// The 6-digit linear sRGB <-> XYZ matrices (ITU-R BT.709 primaries, D65 white) of the paper's
/// optimiser (Jakob and Hanika 2019, supplementary code), used as it uses them.
const XYZ_TO_SRGB: [[f64; 3]; 3] = [
    [3.240479, -1.537150, -0.498535],
    [-0.969256, 1.875991, 0.041556],
    [0.055648, -0.204043, 1.057311],
];
const SRGB_TO_XYZ: [[f64; 3]; 3] = [
    [0.412453, 0.357580, 0.180423],
    [0.212671, 0.715160, 0.072169],
    [0.019334, 0.119193, 0.950227],
];

/// CIE D65 relative SPD, 785-830 nm every 5 nm (CIE S 014-2/E:2006 table 1; camsim-core's D65
/// table stops at 780 nm).
pub const D65_785_830: [f64; 10] = [
    63.8434, 64.304, 61.8779, 59.4519, 55.7054, 51.959, 54.6998, 57.4406, 58.8765, 60.3125,
];

/// Everything the residual needs, precomputed on the quadrature nodes.
pub struct Quadrature {
    /// Node positions in `t` (0..1).
    t: Vec<f64>,
    /// Per node: linear-sRGB weights `M_xyz->rgb (x, y, z)(lambda) I(lambda) w` (the quadrature
    /// weight `w` in nm).
    rgb_weights: Vec<[f64; 3]>,
    /// XYZ of the illuminant (the CIELAB white).
    white: [f64; 3],
}

/// Linear interpolation in a 5 nm table starting at 360 nm, clamped at its ends.
fn lerp_table(data: &[f64], lambda_nm: f64) -> f64 {
    let x = (lambda_nm - LAMBDA_MIN_NM) / 5.0;
    let i = (x.floor().max(0.0) as usize).min(data.len() - 2);
    let f = x - i as f64;
    (1.0 - f) * data[i] + f * data[i + 1]
}

impl Quadrature {
    /// The quadrature for `tables` (95 values each), the white normalised to Y = 1.
    pub fn new(tables: &ObserverTables<'_>) -> Quadrature {
        let intervals = tables.illuminant.len() - 1;
        let n = 3 * intervals + 1;
        let h = (LAMBDA_MAX_NM - LAMBDA_MIN_NM) / (n - 1) as f64;
        let mut t = Vec::with_capacity(n);
        let mut xyz_w = Vec::with_capacity(n);
        let mut white = [0.0; 3];
        for i in 0..n {
            let lambda = LAMBDA_MIN_NM + i as f64 * h;
            // Composite Simpson 3/8: 1, 3, 3, 2, 3, 3, 2, ..., 3, 3, 1 times 3h/8.
            let w = 3.0 * h / 8.0
                * if i == 0 || i == n - 1 {
                    1.0
                } else if i % 3 == 0 {
                    2.0
                } else {
                    3.0
                };
            let e = lerp_table(tables.illuminant, lambda);
            let v: [f64; 3] = std::array::from_fn(|c| lerp_table(tables.cmfs[c], lambda) * e * w);
            for c in 0..3 {
                white[c] += v[c];
            }
            t.push((lambda - LAMBDA_MIN_NM) / (LAMBDA_MAX_NM - LAMBDA_MIN_NM));
            xyz_w.push(v);
        }
        let y = white[1];
        white.iter_mut().for_each(|v| *v /= y);
        let rgb_weights = xyz_w
            .iter()
            .map(|v| std::array::from_fn(|r| (0..3).map(|c| XYZ_TO_SRGB[r][c] * v[c] / y).sum()))
            .collect();
        Quadrature {
            t,
            rgb_weights,
            white,
        }
    }

    /// CIELAB of a linear-sRGB colour against the quadrature's white, and (when `d_rgb` is
    /// given: the derivatives of the colour by the three coefficients, `d_rgb[m][k]` =
    /// d rgb_k / d c_m) the Jacobian `d Lab_i / d c_m` by the chain rule.
    fn lab(&self, rgb: [f64; 3], d_rgb: Option<&[[f64; 3]; 3]>) -> ([f64; 3], [[f64; 3]; 3]) {
        const D: f64 = 6.0 / 29.0;
        let to_xyz = |v: &[f64; 3]| -> [f64; 3] {
            std::array::from_fn(|r| (0..3).map(|c| SRGB_TO_XYZ[r][c] * v[c]).sum())
        };
        let xyz = to_xyz(&rgb);
        // f(v) and f'(v) of CIE 015:2018 eq. 8.3, v = X / Xw (etc.).
        let f = |k: usize| {
            let v = xyz[k] / self.white[k];
            if v > D * D * D {
                let c = v.cbrt();
                (c, 1.0 / (3.0 * c * c * self.white[k]))
            } else {
                (
                    v / (3.0 * D * D) + 4.0 / 29.0,
                    1.0 / (3.0 * D * D * self.white[k]),
                )
            }
        };
        let [(fx, gx), (fy, gy), (fz, gz)] = [f(0), f(1), f(2)];
        let lab = [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)];
        let mut jac = [[0.0; 3]; 3];
        if let Some(d) = d_rgb {
            for (m, dm) in d.iter().enumerate() {
                let dx = to_xyz(dm);
                jac[0][m] = 116.0 * gy * dx[1];
                jac[1][m] = 500.0 * (gx * dx[0] - gy * dx[1]);
                jac[2][m] = 200.0 * (gy * dx[1] - gz * dx[2]);
            }
        }
        (lab, jac)
    }

    /// Linear sRGB of the sigmoid polynomial `c` (in `t`) under the illuminant, and its
    /// derivatives by `c` (`[m][k]` = d rgb_k / d c_m; `S'(x) = 1 / (2 (1 + x^2)^(3/2))`).
    pub fn rgb_of(&self, c: &[f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let mut rgb = [0.0; 3];
        let mut d = [[0.0; 3]; 3];
        for (t, w) in self.t.iter().zip(&self.rgb_weights) {
            let x = (c[0] * t + c[1]) * t + c[2];
            let q = 1.0 / (1.0 + x * x);
            let r = q.sqrt();
            let s = 0.5 + 0.5 * x * r;
            let ds = 0.5 * q * r;
            let powers = [t * t, *t, 1.0];
            for k in 0..3 {
                rgb[k] += w[k] * s;
                for m in 0..3 {
                    d[m][k] += w[k] * ds * powers[m];
                }
            }
        }
        (rgb, d)
    }

    /// Gauss-Newton from `c` toward the coefficients whose colour is `rgb` (module docs; the
    /// Jacobian here is analytic, which the paper's central differences of step 1e-4
    /// approximate to about 1e-8).
    pub fn gauss_newton(&self, rgb: [f64; 3], c: &mut [f64; 3]) {
        let (target, _) = self.lab(rgb, None);
        for _ in 0..15 {
            let (col, d_col) = self.rgb_of(c);
            let (lab, d_lab) = self.lab(col, Some(&d_col));
            // Residual target - Lab(c); its Jacobian is -d_lab, so the step solves
            // d_lab dx = -r and c -= dx (the paper's sign convention).
            let r: [f64; 3] = std::array::from_fn(|k| target[k] - lab[k]);
            let neg: [[f64; 3]; 3] = d_lab.map(|row| row.map(|v| -v));
            let Some(dx) = solve3(neg, r) else {
                return;
            };
            for k in 0..3 {
                c[k] -= dx[k];
            }
            let largest = c[0].max(c[1]).max(c[2]);
            if largest > 200.0 {
                let s = 200.0 / largest;
                c.iter_mut().for_each(|v| *v *= s);
            }
            if r.iter().map(|v| v * v).sum::<f64>() < 1e-6 {
                return;
            }
        }
    }

    /// CIELAB difference (Delta E*ab) between `rgb` and the colour of coefficients `c`.
    pub fn delta_e(&self, rgb: [f64; 3], c: &[f64; 3]) -> f64 {
        let (a, _) = self.lab(rgb, None);
        let (b, _) = self.lab(self.rgb_of(c).0, None);
        (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
    }
}

/// `S(x) = 1/2 + x / (2 sqrt(1 + x^2))` (Jakob and Hanika 2019 eq. 3).
#[inline]
pub fn sigmoid(x: f64) -> f64 {
    0.5 + 0.5 * x / (1.0 + x * x).sqrt()
}

/// Solve `a x = b` by Gaussian elimination with partial pivoting; None when a pivot is below
/// 1e-15 (a degenerate Jacobian).
fn solve3(mut a: [[f64; 3]; 3], mut b: [f64; 3]) -> Option<[f64; 3]> {
    for col in 0..3 {
        let piv = (col..3).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if !(a[piv][col].abs() >= 1e-15) {
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
    Some(x)
}

/// `x^2 (3 - 2x)`.
fn smoothstep(x: f64) -> f64 {
    x * x * (3.0 - 2.0 * x)
}

/// The brightness nodes `smoothstep(smoothstep(k / (res - 1)))`, rounded to f32 (as stored).
pub fn brightness_nodes(res: usize) -> Vec<f32> {
    (0..res)
        .map(|k| smoothstep(smoothstep(k as f64 / (res - 1) as f64)) as f32)
        .collect()
}

/// Index of the coefficients of node (largest component `l`, brightness `k`, ratios `j`, `i`)
/// in a table of resolution `res`.
#[inline]
pub fn node_index(res: usize, l: usize, k: usize, j: usize, i: usize) -> usize {
    ((l * res + k) * res + j) * res + i
}

/// The `res` brightness nodes of one (l, j, i) column (module docs).
pub fn column(q: &Quadrature, res: usize, l: usize, j: usize, i: usize) -> Vec<[f32; 3]> {
    let z = brightness_nodes(res);
    let x = i as f64 / (res - 1) as f64;
    let y = j as f64 / (res - 1) as f64;
    let rgb_at = |k: usize| {
        let b = z[k] as f64;
        let mut rgb = [0.0; 3];
        rgb[l] = b;
        rgb[(l + 1) % 3] = x * b;
        rgb[(l + 2) % 3] = y * b;
        rgb
    };
    let mut out = vec![[0f32; 3]; res];
    let start = res / 5;
    let mut c = [0.0; 3];
    for k in start..res {
        q.gauss_newton(rgb_at(k), &mut c);
        out[k] = c.map(|v| v as f32);
    }
    c = [0.0; 3];
    for k in (0..=start).rev() {
        q.gauss_newton(rgb_at(k), &mut c);
        out[k] = c.map(|v| v as f32);
    }
    out
}

/// The whole table, `3 res^3` coefficient triples indexed by [`node_index`], computed over
/// `threads` threads (the result does not depend on the number).
pub fn generate(q: &Quadrature, res: usize, threads: usize) -> Vec<[f32; 3]> {
    let columns = 3 * res * res;
    let threads = threads.clamp(1, columns);
    let mut table = vec![[0f32; 3]; 3 * res * res * res];
    let parts: Vec<Vec<(usize, Vec<[f32; 3]>)>> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                s.spawn(move || {
                    (t..columns)
                        .step_by(threads)
                        .map(|col| {
                            let (l, j, i) = (col / (res * res), col / res % res, col % res);
                            (col, column(q, res, l, j, i))
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("coefficient table thread"))
            .collect()
    });
    for (col, values) in parts.into_iter().flatten() {
        let (l, j, i) = (col / (res * res), col / res % res, col % res);
        for (k, v) in values.into_iter().enumerate() {
            table[node_index(res, l, k, j, i)] = v;
        }
    }
    table
}
