//! The CIE daylight basis (CIE 015:2018 sec. 4.1.2 and Table 6, from Judd, MacAdam and
//! Wyszecki, "Spectral distribution of typical daylight as a function of correlated colour
//! temperature", JOSA 54, 1964): any daylight spectrum is `S0 + M1 S1 + M2 S2`, the mean and
//! the first two characteristic vectors, with `M1`, `M2` set by the daylight's chromaticity.
//! Environment maps with a spectral basis ([`crate::scene::EnvironmentMap::basis`]) store the
//! coefficients `(k, k M1, k M2)` per texel (the spectral sky of `camsim-compose`).

use camsim_core::{colorimetry::Cmfs, Spectrum, WavelengthGrid};
use std::sync::OnceLock;

/// First wavelength of [`S0_S1_S2`], nm.
pub const BASIS_START_NM: f64 = 300.0;
/// Step of [`S0_S1_S2`], nm.
pub const BASIS_STEP_NM: f64 = 10.0;

/// `[S0, S1, S2]` at 300, 310, ..., 830 nm: CIE 015:2018 Table 6 ("Components S0(lambda),
/// S1(lambda), S2(lambda) of the relative spectral distribution of daylight", identical to CIE
/// 015:2004 Table T.2 and Wyszecki and Stiles, Color Science, 2nd ed., Table V(3.3.4)); S0 is
/// 100 at 560 nm.
#[rustfmt::skip]
pub const S0_S1_S2: [[f64; 3]; 54] = [
    [0.04, 0.02, 0.00], [6.00, 4.50, 2.00], [29.60, 22.40, 4.00], [55.30, 42.00, 8.50],
    [57.30, 40.60, 7.80], [61.80, 41.60, 6.70], [61.50, 38.00, 5.30], [68.80, 42.40, 6.10],
    [63.40, 38.50, 3.00], [65.80, 35.00, 1.20], [94.80, 43.40, -1.10], [104.80, 46.30, -0.50],
    [105.90, 43.90, -0.70], [96.80, 37.10, -1.20], [113.90, 36.70, -2.60], [125.60, 35.90, -2.90],
    [125.50, 32.60, -2.80], [121.30, 27.90, -2.60], [121.30, 24.30, -2.60], [113.50, 20.10, -1.80],
    [113.10, 16.20, -1.50], [110.80, 13.20, -1.30], [106.50, 8.60, -1.20], [108.80, 6.10, -1.00],
    [105.30, 4.20, -0.50], [104.40, 1.90, -0.30], [100.00, 0.00, 0.00], [96.00, -1.60, 0.20],
    [95.10, -3.50, 0.50], [89.10, -3.50, 2.10], [90.50, -5.80, 3.20], [90.30, -7.20, 4.10],
    [88.40, -8.60, 4.70], [84.00, -9.50, 5.10], [85.10, -10.90, 6.70], [81.90, -10.70, 7.30],
    [82.60, -12.00, 8.60], [84.90, -14.00, 9.80], [81.30, -13.60, 10.20], [71.90, -12.00, 8.30],
    [74.30, -13.30, 9.60], [76.40, -12.90, 8.50], [63.30, -10.60, 7.00], [71.70, -11.60, 7.60],
    [77.00, -12.20, 8.00], [65.20, -10.20, 6.70], [47.70, -7.80, 5.20], [68.60, -11.20, 7.40],
    [65.00, -10.40, 6.80], [66.00, -10.60, 7.00], [61.00, -9.70, 6.40], [53.30, -8.30, 5.50],
    [58.90, -9.30, 6.10], [61.90, -9.80, 6.50],
];

/// The basis `[S0, S1, S2]` as spectra (relative units, S0(560 nm) = 100; zero outside
/// 300-830 nm), linearly interpolated between the 10 nm samples.
pub fn basis() -> &'static [Spectrum; 3] {
    static B: OnceLock<[Spectrum; 3]> = OnceLock::new();
    B.get_or_init(|| {
        std::array::from_fn(|k| {
            let pairs: Vec<(f64, f64)> = S0_S1_S2
                .iter()
                .enumerate()
                .map(|(i, row)| (BASIS_START_NM + BASIS_STEP_NM * i as f64, row[k]))
                .collect();
            Spectrum::from_pairs(&pairs)
        })
    })
}

/// The 1 nm grid the basis's colorimetric integrals are taken on (360-830 nm, the CMFs' range).
fn integral_grid() -> WavelengthGrid {
    WavelengthGrid {
        start_nm: 360.0,
        step_nm: 1.0,
        count: 471,
    }
}

/// CIE 1931 tristimulus integrals `[X, Y, Z]` of S0, S1, S2 (sum over 360-830 nm at 1 nm of the
/// CMFs times the linearly interpolated basis, times 1 nm).
pub fn basis_xyz() -> &'static [[f64; 3]; 3] {
    static XYZ: OnceLock<[[f64; 3]; 3]> = OnceLock::new();
    XYZ.get_or_init(|| {
        let grid = integral_grid();
        let cmfs = Cmfs::on(&grid);
        std::array::from_fn(|k| cmfs.xyz(&basis()[k].sample(&grid)))
    })
}

/// `(M1, M2)` of the daylight-basis spectrum `S0 + M1 S1 + M2 S2` whose CIE 1931 chromaticity is
/// exactly `(x, y)` (the two linear equations `X - x (X + Y + Z) = 0`, `Y - y (X + Y + Z) = 0`
/// solved with [`basis_xyz`]; CIE 015's closed form, [`cie_m1_m2`], is the same solution with
/// its integrals rounded). `None` for a chromaticity the basis cannot reach (singular system or
/// non-finite input).
pub fn m1_m2(x: f64, y: f64) -> Option<[f64; 2]> {
    if !(x.is_finite() && y.is_finite()) {
        return None;
    }
    let b = basis_xyz();
    // Row r of the system: f_r(S) = X - x S_sum (r = 0), Y - y S_sum (r = 1).
    let f = |k: usize, r: usize| {
        let s = b[k][0] + b[k][1] + b[k][2];
        b[k][r] - [x, y][r] * s
    };
    let (a11, a12, a21, a22) = (f(1, 0), f(2, 0), f(1, 1), f(2, 1));
    let (r1, r2) = (-f(0, 0), -f(0, 1));
    let det = a11 * a22 - a12 * a21;
    if det.abs() < 1e-12 * (a11.abs() + a12.abs()) * (a21.abs() + a22.abs()) {
        return None;
    }
    let m = [(r1 * a22 - a12 * r2) / det, (a11 * r2 - a21 * r1) / det];
    m.iter().all(|v| v.is_finite()).then_some(m)
}

/// The chromaticity toward which [`m1_m2_non_negative`] moves one the basis cannot reach with a
/// non-negative spectrum when the daylight locus at its x is not reachable either: CIE D65's
/// (0.31272, 0.32903).
pub const FALLBACK_WHITE_XY: [f64; 2] = [0.31272, 0.32903];

/// The CIE daylight locus `y_D = -3.000 x^2 + 2.870 x - 0.275` (CIE 015:2018 eq. 4.6; defined
/// for 4000-25000 K, used beyond as a direction to move toward).
pub fn daylight_locus_y(x: f64) -> f64 {
    -3.0 * x * x + 2.870 * x - 0.275
}

/// True when `S0 + M1 S1 + M2 S2` is non-negative over 380-780 nm (exact: the basis is linear
/// between its 10 nm samples, so the table's samples there decide).
pub fn non_negative_visible(m: [f64; 2]) -> bool {
    let first = ((380.0 - BASIS_START_NM) / BASIS_STEP_NM) as usize;
    let last = ((780.0 - BASIS_START_NM) / BASIS_STEP_NM) as usize;
    S0_S1_S2[first..=last]
        .iter()
        .all(|r| r[0] + m[0] * r[1] + m[1] * r[2] >= 0.0)
}

/// `(M1, M2, (x', y'))`: [`m1_m2`] of the chromaticity nearest `(x, y)` along a segment toward
/// a target for which the spectrum is non-negative over 380-780 nm ([`non_negative_visible`];
/// bisection to 1e-6 of the segment). The target is the daylight locus at the same x
/// ([`daylight_locus_y`]), or D65 ([`FALLBACK_WHITE_XY`]) when that is not reachable either;
/// `(x', y') = (x, y)` when `(x, y)` is. Daylight-basis spectra of chromaticities off the
/// daylight locus (Preetham's sky next to a setting sun: x 0.42, y 0.44) dip below zero in the
/// violet; this moves them toward the locus until they do not. `None` when no target works.
pub fn m1_m2_non_negative(x: f64, y: f64) -> Option<([f64; 2], [f64; 2])> {
    let m0 = m1_m2(x, y)?;
    if non_negative_visible(m0) {
        return Some((m0, [x, y]));
    }
    for target in [[x, daylight_locus_y(x)], FALLBACK_WHITE_XY] {
        let at = |t: f64| [x + t * (target[0] - x), y + t * (target[1] - y)];
        let ok = |t: f64| {
            let c = at(t);
            m1_m2(c[0], c[1]).is_some_and(non_negative_visible)
        };
        if !ok(1.0) {
            continue;
        }
        let (mut lo, mut hi) = (0.0, 1.0);
        while hi - lo > 1e-6 {
            let mid = 0.5 * (lo + hi);
            if ok(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let c = at(hi);
        return Some((m1_m2(c[0], c[1])?, c));
    }
    None
}

/// CIE 015:2018 eq. 4.7-4.9: `M = -1.3515 - 1.7703 x + 5.9114 y`, ... over
/// `0.0241 + 0.2562 x - 0.7341 y` (the published rounded closed form of [`m1_m2`]).
pub fn cie_m1_m2(x: f64, y: f64) -> [f64; 2] {
    let d = 0.0241 + 0.2562 * x - 0.7341 * y;
    [
        (-1.3515 - 1.7703 * x + 5.9114 * y) / d,
        (0.0300 - 31.4424 * x + 30.0717 * y) / d,
    ]
}

/// `S0 + M1 S1 + M2 S2` at `wavelength_nm` (relative units).
pub fn eval(m: [f64; 2], wavelength_nm: f64) -> f64 {
    let b = basis();
    b[0].eval(wavelength_nm) + m[0] * b[1].eval(wavelength_nm) + m[1] * b[2].eval(wavelength_nm)
}

/// The photometric integral `sum y_bar (S0 + M1 S1 + M2 S2)` over 360-830 nm at 1 nm (times
/// 683 lm/W: the luminance in cd/m^2 of a unit coefficient `k = 1` in W/(sr m^2 nm)).
pub fn y_integral(m: [f64; 2]) -> f64 {
    let b = basis_xyz();
    b[0][1] + m[0] * b[1][1] + m[1] * b[2][1]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table reproduces CIE D65 (published at 5 nm in camsim-core, from CIE 015) at its
    /// 10 nm points from D65's chromaticity (0.31272, 0.32903) through the exact solve (CIE
    /// computed D65 with M1 = -0.295, M2 = -0.689; the solve gives -0.2949, -0.6920), and the
    /// CIE's closed form gives nearly the same M1, M2.
    #[test]
    fn basis_reproduces_d65() {
        let d65 = camsim_core::tables::illuminant("D65").unwrap();
        let (x, y) = (0.31272, 0.32903);
        let cie = cie_m1_m2(x, y);
        let exact = m1_m2(x, y).unwrap();
        // The closed form's rounded integrals (CIE: 10 nm sums) and the 1 nm integrals here
        // differ by 0.004 in M1 and 0.023 in M2 (0.2 % of the spectrum at most, S2 <= 10).
        assert!(
            (cie[0] - exact[0]).abs() < 0.01 && (cie[1] - exact[1]).abs() < 0.03,
            "{cie:?} vs {exact:?}"
        );
        for i in 0..49 {
            let l = 300.0 + 10.0 * i as f64;
            let want = d65.eval(l);
            let got = eval(exact, l);
            assert!(
                (got - want).abs() < 0.05 + 0.002 * want,
                "{l} nm: {got} vs D65 {want}"
            );
        }
        let xyz = {
            let g = integral_grid();
            let v: Vec<f64> = (0..g.count)
                .map(|i| eval(exact, g.wavelength_nm(i)))
                .collect();
            camsim_core::colorimetry::xyz(&v, &g)
        };
        let s = xyz[0] + xyz[1] + xyz[2];
        assert!((xyz[0] / s - x).abs() < 1e-9 && (xyz[1] / s - y).abs() < 1e-9);
    }

    /// A chromaticity the basis reaches non-negatively is kept; a greenish-warm one next to a
    /// setting sun (0.42, 0.44) is moved down toward the daylight locus at its x, just far
    /// enough (a little less would be negative at some visible wavelength).
    #[test]
    fn non_negative_solve_moves_toward_the_locus() {
        let (m, used) = m1_m2_non_negative(0.31, 0.33).unwrap();
        assert_eq!(used, [0.31, 0.33]);
        assert_eq!(m, m1_m2(0.31, 0.33).unwrap());
        assert!(!non_negative_visible(m1_m2(0.42, 0.44).unwrap()));
        let (m, used) = m1_m2_non_negative(0.42, 0.44).unwrap();
        assert!(non_negative_visible(m));
        assert!(used[0] == 0.42 && used[1] < 0.44 && used[1] > daylight_locus_y(0.42));
        let nearer = m1_m2(0.42, used[1] + 1e-4).unwrap();
        assert!(!non_negative_visible(nearer));
    }
}
