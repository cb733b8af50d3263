//! Colorimetry: CIE 1931 tristimulus values, luminance, chromaticity, and the sRGB colour space
//! (IEC 61966-2-1:1999).
//!
//! Integrals over wavelength are Riemann sums on the spectrum's [`WavelengthGrid`]:
//! `X = sum_i x_bar(lambda_i) S(lambda_i) step_nm` (CIE 015:2018 section 7, with the CMFs linearly
//! interpolated to the grid as ISETCam's `ieXYZFromEnergy` does).

use crate::error::{CoreError, Result};
use crate::grid::WavelengthGrid;
use crate::tables;
use crate::units::LUMINOUS_EFFICACY_LM_PER_W;

/// The CIE 1931 colour-matching functions sampled on one grid, for repeated (per-pixel) use.
#[derive(Debug, Clone, PartialEq)]
pub struct Cmfs {
    /// The grid the functions are sampled on.
    pub grid: WavelengthGrid,
    /// x-bar at each band of `grid` (dimensionless).
    pub x: Vec<f64>,
    /// y-bar at each band of `grid` (dimensionless; the photopic luminous efficiency V(lambda)).
    pub y: Vec<f64>,
    /// z-bar at each band of `grid` (dimensionless).
    pub z: Vec<f64>,
}

impl Cmfs {
    /// The CIE 1931 2-degree CMFs linearly interpolated onto `grid` (zero outside 360-830 nm).
    pub fn on(grid: &WavelengthGrid) -> Cmfs {
        let [x, y, z] = tables::cie1931_xyz_cmfs();
        Cmfs {
            grid: *grid,
            x: x.sample(grid),
            y: y.sample(grid),
            z: z.sample(grid),
        }
    }

    /// Unscaled tristimulus values `[sum x_bar S dl, sum y_bar S dl, sum z_bar S dl]` of `values`
    /// sampled on this grid (units: those of `values` times nm). `values` must have one entry per
    /// band; extra entries (or missing bands) are ignored.
    pub fn xyz(&self, values: &[f64]) -> [f64; 3] {
        debug_assert_eq!(
            values.len(),
            self.grid.len(),
            "Cmfs::xyz: values must match the grid"
        );
        let (mut sx, mut sy, mut sz) = (0.0, 0.0, 0.0);
        for (((v, x), y), z) in values.iter().zip(&self.x).zip(&self.y).zip(&self.z) {
            sx += x * v;
            sy += y * v;
            sz += z * v;
        }
        let d = self.grid.step_nm;
        [sx * d, sy * d, sz * d]
    }

    /// Same as [`Cmfs::xyz`] for f32 values (a pixel of a spectral image), accumulated in f64.
    pub fn xyz_f32(&self, values: &[f32]) -> [f64; 3] {
        debug_assert_eq!(
            values.len(),
            self.grid.len(),
            "Cmfs::xyz_f32: values must match the grid"
        );
        let (mut sx, mut sy, mut sz) = (0.0, 0.0, 0.0);
        for (((v, x), y), z) in values.iter().zip(&self.x).zip(&self.y).zip(&self.z) {
            let v = *v as f64;
            sx += x * v;
            sy += y * v;
            sz += z * v;
        }
        let d = self.grid.step_nm;
        [sx * d, sy * d, sz * d]
    }

    /// Luminance in cd/m^2 of a spectral radiance in W/(sr m^2 nm) sampled on this grid:
    /// `683 lm/W * sum y_bar L dl` (CIE 015:2018 eq. 7.1 with K_m = 683 lm/W; ISETCam `ieLuminanceFromEnergy`).
    pub fn luminance_cd_m2(&self, radiance_w_per_sr_m2_nm: &[f64]) -> f64 {
        LUMINOUS_EFFICACY_LM_PER_W * self.xyz(radiance_w_per_sr_m2_nm)[1]
    }
}

/// Unscaled CIE 1931 tristimulus values of `spectrum_values` sampled on `grid`:
/// `X = sum x_bar S step_nm` (and Y, Z alike). For many spectra on one grid use [`Cmfs`].
/// `spectrum_values` should have one entry per band; extra entries are ignored. See [`try_xyz`].
pub fn xyz(spectrum_values: &[f64], grid: &WavelengthGrid) -> [f64; 3] {
    Cmfs::on(grid).xyz(spectrum_values)
}

/// [`xyz`] that checks the number of values against the grid.
pub fn try_xyz(spectrum_values: &[f64], grid: &WavelengthGrid) -> Result<[f64; 3]> {
    if spectrum_values.len() != grid.len() {
        return Err(CoreError::invalid(
            "tristimulus integral",
            format!(
                "{} values for a grid of {} bands",
                spectrum_values.len(),
                grid.len()
            ),
        ));
    }
    Ok(xyz(spectrum_values, grid))
}

/// Luminance in cd/m^2 of a spectral radiance in W/(sr m^2 nm) on `grid`: `683 sum y_bar L step_nm`
/// (CIE 015:2018; ISETCam `ieLuminanceFromEnergy`).
pub fn luminance_cd_m2(radiance_w_per_sr_m2_nm: &[f64], grid: &WavelengthGrid) -> f64 {
    Cmfs::on(grid).luminance_cd_m2(radiance_w_per_sr_m2_nm)
}

/// Relative tristimulus values of a reflectance (or transmittance) under an illuminant, both on
/// `grid`, scaled so that a perfect reflector has Y = 100 (CIE 015:2018 eq. 7.2-7.4, k = 100 / sum y_bar S).
/// Returns zeros if the illuminant has no luminance.
pub fn xyz_of_reflectance(
    reflectance: &[f64],
    illuminant: &[f64],
    grid: &WavelengthGrid,
) -> [f64; 3] {
    let cmfs = Cmfs::on(grid);
    let white_y = cmfs.xyz(illuminant)[1];
    if white_y <= 0.0 {
        return [0.0; 3];
    }
    let product: Vec<f64> = reflectance
        .iter()
        .zip(illuminant)
        .map(|(r, s)| r * s)
        .collect();
    let t = cmfs.xyz(&product);
    let k = 100.0 / white_y;
    [t[0] * k, t[1] * k, t[2] * k]
}

/// CIE 1931 chromaticity `[x, y]` of tristimulus values: x = X/(X+Y+Z), y = Y/(X+Y+Z).
/// Returns `[0, 0]` for black (X+Y+Z = 0).
pub fn chromaticity_xy(xyz: [f64; 3]) -> [f64; 2] {
    let s = xyz[0] + xyz[1] + xyz[2];
    if s == 0.0 {
        [0.0, 0.0]
    } else {
        [xyz[0] / s, xyz[1] / s]
    }
}

/// Tristimulus values from chromaticity `x, y` and luminance factor `big_y`:
/// X = x Y / y, Z = (1 - x - y) Y / y. Returns zeros when y = 0.
pub fn xyy_to_xyz(x: f64, y: f64, big_y: f64) -> [f64; 3] {
    if y == 0.0 {
        return [0.0; 3];
    }
    [x * big_y / y, big_y, (1.0 - x - y) * big_y / y]
}

/// CIE 1960 UCS chromaticity `[u, v]`: u = 4X/(X+15Y+3Z), v = 6Y/(X+15Y+3Z) (CIE 015:2018).
pub fn chromaticity_uv_1960(xyz: [f64; 3]) -> [f64; 2] {
    let d = xyz[0] + 15.0 * xyz[1] + 3.0 * xyz[2];
    if d == 0.0 {
        [0.0, 0.0]
    } else {
        [4.0 * xyz[0] / d, 6.0 * xyz[1] / d]
    }
}

/// sRGB / Rec. 709 D65 white point chromaticity (IEC 61966-2-1:1999).
pub const SRGB_WHITE_XY: [f64; 2] = [0.3127, 0.3290];

/// XYZ (Y = 1 for white) -> linear sRGB, the matrix of IEC 61966-2-1:1999 section 5.2.
pub const XYZ_TO_LINEAR_SRGB: [[f64; 3]; 3] = [
    [3.2406, -1.5372, -0.4986],
    [-0.9689, 1.8758, 0.0415],
    [0.0557, -0.2040, 1.0570],
];

/// Linear sRGB -> XYZ, the matrix of IEC 61966-2-1:1999 section 5.3 (inverse encoding).
pub const LINEAR_SRGB_TO_XYZ: [[f64; 3]; 3] = [
    [0.4124, 0.3576, 0.1805],
    [0.2126, 0.7152, 0.0722],
    [0.0193, 0.1192, 0.9505],
];

/// 3x3 matrix times column vector.
pub fn mat3_mul_vec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// XYZ (white Y = 1) -> linear sRGB (not clipped).
pub fn xyz_to_linear_srgb(xyz: [f64; 3]) -> [f64; 3] {
    mat3_mul_vec(&XYZ_TO_LINEAR_SRGB, xyz)
}

/// Linear sRGB -> XYZ (white Y = 1).
pub fn linear_srgb_to_xyz(rgb: [f64; 3]) -> [f64; 3] {
    mat3_mul_vec(&LINEAR_SRGB_TO_XYZ, rgb)
}

/// Inverse of a 3x3 matrix by its adjugate (`None` when the determinant is 0 or not finite).
pub fn mat3_inverse(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let c = |r: usize, k: usize| {
        let (r1, r2) = ((r + 1) % 3, (r + 2) % 3);
        let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
        m[r1][k1] * m[r2][k2] - m[r1][k2] * m[r2][k1]
    };
    let det = m[0][0] * c(0, 0) + m[0][1] * c(0, 1) + m[0][2] * c(0, 2);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    // inverse[i][j] = cofactor[j][i] / det (cyclic indices give the cofactor signs).
    Some([0, 1, 2].map(|i| [0, 1, 2].map(|j| c(j, i) / det)))
}

/// The Bradford cone-response matrix (Lam 1985; as tabulated by B. Lindbloom, "Chromatic
/// Adaptation").
pub const BRADFORD: [[f64; 3]; 3] = [
    [0.8951, 0.2664, -0.1614],
    [-0.7502, 1.7135, 0.0367],
    [0.0389, -0.0685, 1.0296],
];

/// Bradford chromatic adaptation matrix taking colours seen under white `src_white_xyz` to
/// corresponding colours under `dst_white_xyz`: `M_B^-1 diag(rho_dst / rho_src) M_B`
/// (von Kries scaling in the Bradford cone space; Lindbloom's "linear Bradford").
pub fn bradford_adaptation(src_white_xyz: [f64; 3], dst_white_xyz: [f64; 3]) -> [[f64; 3]; 3] {
    let s = mat3_mul_vec(&BRADFORD, src_white_xyz);
    let d = mat3_mul_vec(&BRADFORD, dst_white_xyz);
    let inv = mat3_inverse(&BRADFORD).expect("the Bradford matrix is invertible");
    // inv * diag(d / s) * BRADFORD
    [0, 1, 2].map(|r| {
        [0, 1, 2].map(|c| {
            (0..3)
                .map(|k| inv[r][k] * d[k] / s[k] * BRADFORD[k][c])
                .sum()
        })
    })
}

/// sRGB transfer function (IEC 61966-2-1:1999 eq. 5.5-5.6): linear value in [0, 1] -> encoded value.
/// 12.92 v for v <= 0.0031308, else 1.055 v^(1/2.4) - 0.055. Input is clipped to [0, 1]
/// (NaN gives 0).
pub fn srgb_encode(linear: f64) -> f64 {
    let v = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Inverse of [`srgb_encode`] (IEC 61966-2-1:1999 eq. 5.2-5.3): encoded value in [0, 1] -> linear.
/// v / 12.92 for v <= 0.04045, else ((v + 0.055) / 1.055)^2.4. Input clipped to [0, 1].
pub fn srgb_decode(encoded: f64) -> f64 {
    let v = if encoded.is_nan() {
        0.0
    } else {
        encoded.clamp(0.0, 1.0)
    };
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear sRGB in [0, 1] -> 8-bit sRGB code value (rounded).
pub fn srgb_encode_u8(linear: f64) -> u8 {
    (srgb_encode(linear) * 255.0).round() as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mat3_inverse_inverts_and_refuses_singular_matrices() {
        let m = [[2.0, -1.0, 0.5], [0.3, 4.0, -2.0], [1.0, 0.25, 3.0]];
        let inv = mat3_inverse(&m).unwrap();
        for r in 0..3 {
            for c in 0..3 {
                let v: f64 = (0..3).map(|k| m[r][k] * inv[k][c]).sum();
                assert!(
                    (v - f64::from(u8::from(r == c))).abs() < 1e-14,
                    "{r} {c}: {v}"
                );
            }
        }
        assert!(mat3_inverse(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 5.0]]).is_none());
        // Bradford from a white to itself is the identity; to another white it maps white to white.
        let (d65, e) = ([0.95047, 1.0, 1.08883], [1.0, 1.0, 1.0]);
        let a = bradford_adaptation(d65, e);
        let w = mat3_mul_vec(&a, d65);
        assert!(w.iter().all(|v| (v - 1.0).abs() < 1e-12), "{w:?}");
    }

    #[test]
    fn srgb_transfer_round_trips_and_is_continuous() {
        for i in 0..=100 {
            let v = i as f64 / 100.0;
            assert!((srgb_decode(srgb_encode(v)) - v).abs() < 1e-12);
        }
        // The two pieces meet at the break point (IEC 61966-2-1: 0.0031308 <-> 0.04045) to 1e-6.
        let lin = 0.003_130_8;
        assert!((12.92 * lin - (1.055 * f64::powf(lin, 1.0 / 2.4) - 0.055)).abs() < 1e-6);
        assert_eq!(srgb_encode(-1.0), 0.0);
        assert_eq!(srgb_encode(f64::NAN), 0.0);
        assert_eq!(srgb_encode_u8(1.0), 255);
        // 18 % grey encodes to 118 (0.4613 * 255), the commonly quoted sRGB middle grey.
        assert_eq!(srgb_encode_u8(0.18), 118);
    }

    #[test]
    fn try_xyz_checks_lengths() {
        let g = WavelengthGrid::default();
        let e = try_xyz(&[1.0; 30], &g).unwrap_err().to_string();
        assert!(e.contains("30 values") && e.contains("31 bands"), "{e}");
        // On a grid the CMF table is sampled on, try_xyz is the plain sum x_bar S step.
        let g5 = WavelengthGrid::new(360.0, 830.0, 5.0).unwrap();
        let ones = vec![1.0; g5.len()];
        let y = try_xyz(&ones, &g5).unwrap()[1];
        let direct: f64 = Cmfs::on(&g5).y.iter().sum::<f64>() * 5.0;
        assert!((y - direct).abs() < 1e-9 * direct, "{y} vs {direct}");
    }

    #[test]
    fn equal_energy_white_is_at_one_third_and_integrates_v_lambda() {
        // CIE 015:2018: the CIE 1931 CMFs are normalised so that the equal-energy illuminant E
        // has equal X, Y, Z, i.e. x = y = 1/3. On the 5 nm table the three integrals differ by
        // about 3e-4 of their value (sampling of the 1 nm definition), so x and y are 1/3 to
        // within 2e-4.
        let g = WavelengthGrid::new(360.0, 830.0, 5.0).unwrap();
        let xyz_e = try_xyz(&vec![1.0; g.len()], &g).unwrap();
        let [x, y] = chromaticity_xy(xyz_e);
        assert!(
            (x - 1.0 / 3.0).abs() < 2e-4 && (y - 1.0 / 3.0).abs() < 2e-4,
            "x {x} y {y}"
        );
        // Y of E (1 W/nm everywhere) is the integral of V(lambda) = 106.857 nm (CIE 015:2018 table
        // sums: 21.3714 x 5 nm); luminance of a flat 1 W/(sr m^2 nm) radiance is 683 x that.
        assert!((xyz_e[1] - 106.857).abs() < 0.01, "Y = {}", xyz_e[1]);
        let lum = luminance_cd_m2(&vec![1.0; g.len()], &g);
        assert!((lum / (683.0 * 106.857) - 1.0).abs() < 1e-4, "{lum}");
    }

    #[test]
    fn chromaticity_helpers_invert() {
        let xyz = xyy_to_xyz(0.3127, 0.3290, 1.0);
        let xy = chromaticity_xy(xyz);
        assert!((xy[0] - 0.3127).abs() < 1e-12 && (xy[1] - 0.3290).abs() < 1e-12);
        assert_eq!(chromaticity_xy([0.0; 3]), [0.0, 0.0]);
        // Equal-energy white: u = 4/19, v = 6/19 (CIE 1960 UCS).
        let uv = chromaticity_uv_1960([1.0, 1.0, 1.0]);
        assert!((uv[0] - 4.0 / 19.0).abs() < 1e-12 && (uv[1] - 6.0 / 19.0).abs() < 1e-12);
    }
}
