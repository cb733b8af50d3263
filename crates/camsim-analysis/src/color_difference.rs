//! CIELAB, CIELUV and the CIEDE2000, CIE94 and CIE 1976 u*v* colour differences.
//!
//! - [`xyz_to_lab`]: CIE 1976 L*a*b* from tristimulus values and the reference white
//!   (CIE 015:2018 §8.2.1, with the linear segment below (6/29)^3).
//! - [`ciede2000`]: the CIEDE2000 total colour difference with k_L = k_C = k_H = 1
//!   (CIE 142-2001; implementation notes and test data: G. Sharma, W. Wu, E. N. Dalal, "The
//!   CIEDE2000 color-difference formula: implementation notes, supplementary test data, and
//!   mathematical observations", Color Res. Appl. 30(1), 21-30, 2005).

/// CIE L*, a*, b* of a colour (L* in [0, 100] for colours no lighter than the white).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Lab {
    /// Lightness L*.
    pub l: f64,
    /// Red-green opponent coordinate a*.
    pub a: f64,
    /// Yellow-blue opponent coordinate b*.
    pub b: f64,
}

impl Lab {
    /// A colour from its three coordinates.
    pub fn new(l: f64, a: f64, b: f64) -> Lab {
        Lab { l, a, b }
    }
}

/// CIELAB of tristimulus values `xyz` relative to the reference white `white_xyz` (same units,
/// e.g. both with Y_white = 100 or both in cd/m^2). CIE 015:2018 eqs. 8.11-8.13:
/// `L* = 116 f(Y/Yn) - 16`, `a* = 500 [f(X/Xn) - f(Y/Yn)]`, `b* = 200 [f(Y/Yn) - f(Z/Zn)]`, with
/// `f(t) = t^(1/3)` for `t > (6/29)^3` and `f(t) = t / (3 (6/29)^2) + 4/29` below.
/// A white component that is not positive gives NaN (no meaningful ratio).
pub fn xyz_to_lab(xyz: [f64; 3], white_xyz: [f64; 3]) -> Lab {
    const DELTA: f64 = 6.0 / 29.0;
    let f = |t: f64| {
        if t > DELTA * DELTA * DELTA {
            t.cbrt()
        } else {
            t / (3.0 * DELTA * DELTA) + 4.0 / 29.0
        }
    };
    let ratio = |v: f64, n: f64| if n > 0.0 { v / n } else { f64::NAN };
    let fx = f(ratio(xyz[0], white_xyz[0]));
    let fy = f(ratio(xyz[1], white_xyz[1]));
    let fz = f(ratio(xyz[2], white_xyz[2]));
    Lab {
        l: 116.0 * fy - 16.0,
        a: 500.0 * (fx - fy),
        b: 200.0 * (fy - fz),
    }
}

/// CIEDE2000 colour difference ΔE00 between two CIELAB colours, parametric factors
/// k_L = k_C = k_H = 1 (CIE 142-2001; the steps and hue conventions follow Sharma, Wu & Dalal
/// 2005 eqs. 1-22: hue angles in [0, 360), the mean hue of a pair whose hues differ by more than
/// 180 degrees taken the short way round, and a zero-chroma colour's hue taken as 0).
pub fn ciede2000(lab1: Lab, lab2: Lab) -> f64 {
    let pow7 = |x: f64| x.powi(7);
    let twenty_five_7 = pow7(25.0);
    // Eqs. 2-6: a* rescaled by G, then C' and h'.
    let c_ab_mean = 0.5 * (lab1.a.hypot(lab1.b) + lab2.a.hypot(lab2.b));
    let g = 0.5 * (1.0 - (pow7(c_ab_mean) / (pow7(c_ab_mean) + twenty_five_7)).sqrt());
    let prime = |lab: Lab| {
        let a = (1.0 + g) * lab.a;
        let c = a.hypot(lab.b);
        let h_deg = if a == 0.0 && lab.b == 0.0 {
            0.0
        } else {
            lab.b.atan2(a).to_degrees().rem_euclid(360.0)
        };
        (c, h_deg)
    };
    let (c1, h1_deg) = prime(lab1);
    let (c2, h2_deg) = prime(lab2);
    // Eqs. 8-10: differences.
    let dl = lab2.l - lab1.l;
    let dc = c2 - c1;
    let dh_deg = if c1 * c2 == 0.0 {
        0.0
    } else {
        let d = h2_deg - h1_deg;
        if d > 180.0 {
            d - 360.0
        } else if d < -180.0 {
            d + 360.0
        } else {
            d
        }
    };
    let dh_big = 2.0 * (c1 * c2).sqrt() * (0.5 * dh_deg).to_radians().sin();
    // Eqs. 12-14: means.
    let l_mean = 0.5 * (lab1.l + lab2.l);
    let c_mean = 0.5 * (c1 + c2);
    let h_mean_deg = if c1 * c2 == 0.0 {
        h1_deg + h2_deg
    } else if (h1_deg - h2_deg).abs() <= 180.0 {
        0.5 * (h1_deg + h2_deg)
    } else if h1_deg + h2_deg < 360.0 {
        0.5 * (h1_deg + h2_deg + 360.0)
    } else {
        0.5 * (h1_deg + h2_deg - 360.0)
    };
    // Eqs. 15-21: weights and the rotation term.
    let cos_deg = |x: f64| x.to_radians().cos();
    let t = 1.0 - 0.17 * cos_deg(h_mean_deg - 30.0)
        + 0.24 * cos_deg(2.0 * h_mean_deg)
        + 0.32 * cos_deg(3.0 * h_mean_deg + 6.0)
        - 0.20 * cos_deg(4.0 * h_mean_deg - 63.0);
    let d_theta_deg = 30.0 * (-((h_mean_deg - 275.0) / 25.0).powi(2)).exp();
    let r_c = 2.0 * (pow7(c_mean) / (pow7(c_mean) + twenty_five_7)).sqrt();
    let l50 = (l_mean - 50.0).powi(2);
    let s_l = 1.0 + 0.015 * l50 / (20.0 + l50).sqrt();
    let s_c = 1.0 + 0.045 * c_mean;
    let s_h = 1.0 + 0.015 * c_mean * t;
    let r_t = -(2.0 * d_theta_deg).to_radians().sin() * r_c;
    // Eq. 22.
    let (x, y, z) = (dl / s_l, dc / s_c, dh_big / s_h);
    (x * x + y * y + z * z + r_t * y * z).sqrt()
}

/// CIE 1994 colour difference ΔE*94 between a reference `lab1` and a sample `lab2` (CIE
/// 116-1995, graphic-arts weights: k_L = k_C = k_H = 1, S_L = 1, S_C = 1 + 0.045 C*_1,
/// S_H = 1 + 0.015 C*_1, C*_1 the reference's chroma; ΔH*^2 = Δa*^2 + Δb*^2 - ΔC*^2). Not
/// symmetric: the weights use the first colour's chroma, as the standard defines.
pub fn cie94(lab1: Lab, lab2: Lab) -> f64 {
    let c1 = lab1.a.hypot(lab1.b);
    let c2 = lab2.a.hypot(lab2.b);
    let dl = lab1.l - lab2.l;
    let dc = c1 - c2;
    let (da, db) = (lab1.a - lab2.a, lab1.b - lab2.b);
    // Rounding can make the hue term a hair negative.
    let dh2 = (da * da + db * db - dc * dc).max(0.0);
    let sc = 1.0 + 0.045 * c1;
    let sh = 1.0 + 0.015 * c1;
    (dl * dl + (dc / sc).powi(2) + dh2 / (sh * sh)).sqrt()
}

/// CIE 1976 L*, u*, v* of tristimulus values relative to the white (CIE 015:2018 eqs. 8.3-8.8:
/// u' = 4X / (X + 15Y + 3Z), v' = 9Y / (X + 15Y + 3Z), u* = 13 L* (u' - u'_n),
/// v* = 13 L* (v' - v'_n), L* as in CIELAB). Black (X + 15Y + 3Z = 0) has u* = v* = 0.
pub fn xyz_to_luv(xyz: [f64; 3], white_xyz: [f64; 3]) -> [f64; 3] {
    let uv = |x: [f64; 3]| {
        let d = x[0] + 15.0 * x[1] + 3.0 * x[2];
        if d > 0.0 {
            Some((4.0 * x[0] / d, 9.0 * x[1] / d))
        } else {
            None
        }
    };
    let l = xyz_to_lab(xyz, white_xyz).l;
    match (uv(xyz), uv(white_xyz)) {
        (Some((u, v)), Some((un, vn))) => [l, 13.0 * l * (u - un), 13.0 * l * (v - vn)],
        (None, Some(_)) => [l, 0.0, 0.0],
        _ => [f64::NAN; 3],
    }
}

/// CIE 1976 ΔE*uv: the Euclidean distance in L*u*v* of two tristimulus values under the same
/// white (CIE 015:2018 eq. 8.9).
pub fn delta_e_uv(xyz1: [f64; 3], xyz2: [f64; 3], white_xyz: [f64; 3]) -> f64 {
    let a = xyz_to_luv(xyz1, white_xyz);
    let b = xyz_to_luv(xyz2, white_xyz);
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sharma, Wu & Dalal (2005), Table 1: the 34 CIEDE2000 test pairs
    /// (L1, a1, b1, L2, a2, b2, ΔE00), as published to four decimals.
    const SHARMA_2005_TABLE_1: [[f64; 7]; 34] = [
        [50.0000, 2.6772, -79.7751, 50.0000, 0.0000, -82.7485, 2.0425],
        [50.0000, 3.1571, -77.2803, 50.0000, 0.0000, -82.7485, 2.8615],
        [50.0000, 2.8361, -74.0200, 50.0000, 0.0000, -82.7485, 3.4412],
        [
            50.0000, -1.3802, -84.2814, 50.0000, 0.0000, -82.7485, 1.0000,
        ],
        [
            50.0000, -1.1848, -84.8006, 50.0000, 0.0000, -82.7485, 1.0000,
        ],
        [
            50.0000, -0.9009, -85.5211, 50.0000, 0.0000, -82.7485, 1.0000,
        ],
        [50.0000, 0.0000, 0.0000, 50.0000, -1.0000, 2.0000, 2.3669],
        [50.0000, -1.0000, 2.0000, 50.0000, 0.0000, 0.0000, 2.3669],
        [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0009, 7.1792],
        [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0010, 7.1792],
        [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0011, 7.2195],
        [50.0000, 2.4900, -0.0010, 50.0000, -2.4900, 0.0012, 7.2195],
        [50.0000, -0.0010, 2.4900, 50.0000, 0.0009, -2.4900, 4.8045],
        [50.0000, -0.0010, 2.4900, 50.0000, 0.0010, -2.4900, 4.8045],
        [50.0000, -0.0010, 2.4900, 50.0000, 0.0011, -2.4900, 4.7461],
        [50.0000, 2.5000, 0.0000, 50.0000, 0.0000, -2.5000, 4.3065],
        [50.0000, 2.5000, 0.0000, 73.0000, 25.0000, -18.0000, 27.1492],
        [50.0000, 2.5000, 0.0000, 61.0000, -5.0000, 29.0000, 22.8977],
        [50.0000, 2.5000, 0.0000, 56.0000, -27.0000, -3.0000, 31.9030],
        [50.0000, 2.5000, 0.0000, 58.0000, 24.0000, 15.0000, 19.4535],
        [50.0000, 2.5000, 0.0000, 50.0000, 3.1736, 0.5854, 1.0000],
        [50.0000, 2.5000, 0.0000, 50.0000, 3.2972, 0.0000, 1.0000],
        [50.0000, 2.5000, 0.0000, 50.0000, 1.8634, 0.5757, 1.0000],
        [50.0000, 2.5000, 0.0000, 50.0000, 3.2592, 0.3350, 1.0000],
        [
            60.2574, -34.0099, 36.2677, 60.4626, -34.1751, 39.4387, 1.2644,
        ],
        [
            63.0109, -31.0961, -5.8663, 62.8187, -29.7946, -4.0864, 1.2630,
        ],
        [61.2901, 3.7196, -5.3901, 61.4292, 2.2480, -4.9620, 1.8731],
        [35.0831, -44.1164, 3.7933, 35.0232, -40.0716, 1.5901, 1.8645],
        [
            22.7233, 20.0904, -46.6940, 23.0331, 14.9730, -42.5619, 2.0373,
        ],
        [36.4612, 47.8580, 18.3852, 36.2715, 50.5065, 21.2231, 1.4146],
        [90.8027, -2.0831, 1.4410, 91.1528, -1.6435, 0.0447, 1.4441],
        [90.9257, -0.5406, -0.9208, 88.6381, -0.8985, -0.7239, 1.5381],
        [6.7747, -0.2908, -2.4247, 5.8714, -0.0985, -2.2286, 0.6377],
        [2.0776, 0.0795, -1.1350, 0.9033, -0.0636, -0.5514, 0.9082],
    ];

    #[test]
    fn ciede2000_matches_sharma_2005_table_1() {
        let mut worst = 0.0f64;
        for (i, row) in SHARMA_2005_TABLE_1.iter().enumerate() {
            let (p, q) = (
                Lab::new(row[0], row[1], row[2]),
                Lab::new(row[3], row[4], row[5]),
            );
            let de = ciede2000(p, q);
            // The table is rounded to 4 decimals: agreement means |error| <= 0.5e-4 (+ float slack).
            let err = (de - row[6]).abs();
            assert!(
                err <= 0.5e-4 + 1e-9,
                "pair {}: {de:.6} vs {:.4}",
                i + 1,
                row[6]
            );
            // Symmetric in its arguments (Sharma et al. 2005 §3).
            assert!(
                (ciede2000(q, p) - de).abs() < 1e-12,
                "pair {} not symmetric",
                i + 1
            );
            worst = worst.max(err);
        }
        eprintln!(
            "CIEDE2000 vs Sharma et al. 2005 Table 1: max |error| = {worst:.2e} over 34 pairs"
        );
    }

    #[test]
    fn ciede2000_of_identical_colours_is_zero_and_lightness_only_pairs_follow_s_l() {
        let p = Lab::new(40.0, 12.0, -30.0);
        assert_eq!(ciede2000(p, p), 0.0);
        // Equal a*, b*: ΔE00 = |ΔL| / S_L (eq. 22 with ΔC' = ΔH' = 0), S_L = 1 at L̄ = 50.
        let de = ciede2000(Lab::new(49.0, 10.0, 10.0), Lab::new(51.0, 10.0, 10.0));
        assert!((de - 2.0).abs() < 1e-12, "{de}");
    }

    #[test]
    fn lab_of_the_white_is_100_0_0_and_the_linear_segment_joins_the_cube_root() {
        let white = [95.047, 100.0, 108.883];
        let w = xyz_to_lab(white, white);
        assert!(
            (w.l - 100.0).abs() < 1e-12 && w.a.abs() < 1e-12 && w.b.abs() < 1e-12,
            "{w:?}"
        );
        // Neutral grey with Y/Yn = 0.18: L* = 116 * 0.18^(1/3) - 16 = 49.4961...
        let g = xyz_to_lab([0.18 * white[0], 18.0, 0.18 * white[2]], white);
        assert!(
            (g.l - (116.0 * 0.18f64.cbrt() - 16.0)).abs() < 1e-12
                && g.a.abs() < 1e-12
                && g.b.abs() < 1e-12
        );
        // Continuity at t = (6/29)^3, and L* = 903.3 Y/Yn (CIE's kappa = 24389/27) below it.
        let t0 = (6.0f64 / 29.0).powi(3);
        let below = xyz_to_lab([0.0, t0 * (1.0 - 1e-12) * 100.0, 0.0], white).l;
        let above = xyz_to_lab([0.0, t0 * (1.0 + 1e-12) * 100.0, 0.0], white).l;
        assert!((below - above).abs() < 1e-8, "{below} vs {above}");
        let dark = xyz_to_lab([0.0, 0.1, 0.0], white).l;
        assert!((dark - 24389.0 / 27.0 * 0.001).abs() < 1e-10, "{dark}");
    }
}
