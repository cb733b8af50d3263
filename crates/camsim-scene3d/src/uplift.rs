//! RGB -> spectrum uplift for reflectances: the sigmoid-polynomial model of
//! W. Jakob and J. Hanika, "A Low-Dimensional Function Space for Efficient Spectral Upsampling",
//! Computer Graphics Forum 38(2), 2019, looked up as pbrt-v4 looks up its sRGB table.
//!
//! A reflectance is `s(lambda) = S(c0 t^2 + c1 t + c2)` with `S(x) = 1/2 + x / (2 sqrt(1 + x^2))`,
//! a sigmoid with values strictly inside (0, 1) (so every uplifted reflectance conserves energy),
//! and `t = (lambda - 360 nm) / (830 nm - 360 nm)` (pbrt-v4 stores the same polynomial in nm).
//!
//! The coefficients come from a table computed at build time by [`crate::rgb2spec`] (the paper's
//! optimisation set up as pbrt-v4's build sets it up for sRGB: CIE 1931 observer and D65 on a
//! Simpson 3/8 quadrature, CIELAB residual, Gauss-Newton from neighbouring solutions, 64 nodes per
//! axis for each largest component, brightness nodes `smoothstep(smoothstep(k / 63))`). A lookup
//! follows pbrt-v4's `RGBToSpectrumTable`: greys (r = g = b) are the exact constant, otherwise the
//! largest component picks the block (ties to the later component, as pbrt-v4), the other two
//! divided by it give the two ratio coordinates, the largest the brightness, and the coefficients
//! are trilinearly interpolated. RGB components are clamped to [0, 1] (pbrt-v4 clamps texture
//! values and rejects `rgb reflectance` components above 1 at parse time, see `camsim_pbrt`).
//!
//! Tested (`tests/it/uplift.rs`): every lookup reproduces its linear-sRGB colour under D65 through an
//! independent 1 nm trapezoid integration of the CIE tables, and the table agrees with an
//! independent solution of the same equations (Newton from scratch on each colour).

use crate::rgb2spec::{self, brightness_nodes, node_index, RES};
use camsim_core::{tables, Spectrum, WavelengthGrid};
use std::sync::OnceLock;

/// Lower end of the fitting range, nm (the CIE 1931 tables' range).
pub const LAMBDA_MIN_NM: f64 = rgb2spec::LAMBDA_MIN_NM;
/// Upper end of the fitting range, nm.
pub const LAMBDA_MAX_NM: f64 = rgb2spec::LAMBDA_MAX_NM;
/// Resolution of the coefficient table per axis (pbrt-v4's 64).
pub const TABLE_RES: usize = RES;

/// The table `build.rs` computed: `3 RES^3` triples of f32 (little-endian), indexed by
/// [`rgb2spec::node_index`].
static TABLE_BYTES: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/srgb_sigmoid_table.bin"));

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

    /// The constant spectrum `v` (0 <= v <= 1) as a sigmoid polynomial (pbrt-v4's grey case:
    /// `c2 = (v - 1/2) / sqrt(v (1 - v))`).
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
    rgb2spec::sigmoid(x)
}

fn clamp_rgb(rgb: [f32; 3]) -> [f64; 3] {
    rgb.map(|v| {
        if v.is_nan() {
            0.0
        } else {
            (v as f64).clamp(0.0, 1.0)
        }
    })
}

/// The brightness nodes of the table (f32, as pbrt-v4 stores them).
fn z_nodes() -> &'static [f32] {
    static Z: OnceLock<Vec<f32>> = OnceLock::new();
    Z.get_or_init(|| brightness_nodes(RES))
}

/// The coefficient triple of one table node.
#[inline]
fn node(i: usize) -> [f32; 3] {
    let b = &TABLE_BYTES[12 * i..12 * i + 12];
    std::array::from_fn(|k| {
        f32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]])
    })
}

/// The coefficients stored at table node (largest component `l`, brightness `k`, ratios `j`,
/// `i`), in the normalised wavelength `t` (tests compare them with [`rgb2spec::column`]).
pub fn table_coefficients(l: usize, k: usize, j: usize, i: usize) -> [f32; 3] {
    node(node_index(RES, l, k, j, i))
}

/// The linear-sRGB colour a table node was solved for.
pub fn table_node_rgb(l: usize, k: usize, j: usize, i: usize) -> [f64; 3] {
    let b = z_nodes()[k] as f64;
    let mut rgb = [0.0; 3];
    rgb[l] = b;
    rgb[(l + 1) % 3] = i as f64 / (RES - 1) as f64 * b;
    rgb[(l + 2) % 3] = j as f64 / (RES - 1) as f64 * b;
    rgb
}

/// Prepare the lookup (the brightness nodes); the table itself is compiled in.
pub fn warm_up() {
    let _ = z_nodes();
}

/// Coefficients for a linear-sRGB reflectance by table lookup (pbrt-v4 `RGBToSpectrumTable`,
/// trilinear interpolation). Components are clamped to [0, 1].
pub fn rgb_to_coefficients(rgb: [f32; 3]) -> SigmoidPolynomial {
    let rgb = clamp_rgb(rgb);
    if rgb[0] == rgb[1] && rgb[1] == rgb[2] {
        return SigmoidPolynomial::constant(rgb[0]);
    }
    let n = RES;
    // Largest component; ties go to the later one, as pbrt-v4's comparisons do.
    let l = if rgb[0] > rgb[1] {
        if rgb[0] > rgb[2] {
            0
        } else {
            2
        }
    } else if rgb[1] > rgb[2] {
        1
    } else {
        2
    };
    let z = rgb[l];
    let x = rgb[(l + 1) % 3] * (n - 1) as f64 / z;
    let y = rgb[(l + 2) % 3] * (n - 1) as f64 / z;
    let xi = (x as usize).min(n - 2);
    let yi = (y as usize).min(n - 2);
    let zs = z_nodes();
    // Largest node index below z (pbrt-v4 FindInterval), within 0..n-2.
    let zi = zs
        .partition_point(|&v| (v as f64) < z)
        .saturating_sub(1)
        .min(n - 2);
    let (dx, dy) = (x - xi as f64, y - yi as f64);
    let dz = (z - zs[zi] as f64) / (zs[zi + 1] as f64 - zs[zi] as f64);
    let mut c = [0.0f64; 3];
    for (dk, wk) in [(0, 1.0 - dz), (1, dz)] {
        for (dj, wj) in [(0, 1.0 - dy), (1, dy)] {
            for (di, wi) in [(0, 1.0 - dx), (1, dx)] {
                let w = wk * wj * wi;
                if w == 0.0 {
                    continue;
                }
                let v = node(node_index(n, l, zi + dk, yi + dj, xi + di));
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

/// The uplifted reflectance of linear-sRGB `rgb` sampled on `grid` (values in [0, 1]).
pub fn rgb_to_reflectance_spectrum(rgb: [f32; 3], grid: &WavelengthGrid) -> Spectrum {
    let p = rgb_to_coefficients(rgb);
    Spectrum::on_grid(
        grid,
        (0..grid.len())
            .map(|i| p.eval(grid.wavelength_nm(i)))
            .collect(),
    )
}

/// The uplifted reflectance of `rgb` on the fitting range, 360-830 nm every 1 nm, for use
/// before the render grid is known.
pub fn rgb_to_reflectance_full(rgb: [f32; 3]) -> Spectrum {
    let p = rgb_to_coefficients(rgb);
    let n = (LAMBDA_MAX_NM - LAMBDA_MIN_NM).round() as usize;
    Spectrum::from_pairs(
        &(0..=n)
            .map(|i| {
                let l = LAMBDA_MIN_NM + i as f64;
                (l, p.eval(l))
            })
            .collect::<Vec<_>>(),
    )
}

/// Linear sRGB of a reflectance spectrum under D65 (white = 1): `M (X, Y, Z)` with the CIE 1931
/// observer and D65 summed every 5 nm over 360-780 nm, normalised so the white has Y = 1, and
/// camsim-core's sRGB matrix.
pub fn reflectance_to_rgb(reflectance: &Spectrum) -> [f64; 3] {
    let [x, y, z] = tables::cie1931_xyz_cmfs();
    let d65 = tables::illuminant("D65").expect("D65 is a built-in table");
    let (mut xyz, mut norm) = ([0.0f64; 3], 0.0);
    for i in 0..=84 {
        let l = LAMBDA_MIN_NM + 5.0 * i as f64;
        let e = d65.eval(l);
        let s = reflectance.eval(l);
        xyz[0] += s * x.eval(l) * e;
        xyz[1] += s * y.eval(l) * e;
        xyz[2] += s * z.eval(l) * e;
        norm += y.eval(l) * e;
    }
    camsim_core::colorimetry::xyz_to_linear_srgb(xyz.map(|v| v / norm))
}
