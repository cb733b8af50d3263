//! Built-in spectral tables: the CIE 1931 2-degree colour-matching functions, CIE illuminants
//! (D65, A, C, F2, F11, equal energy E, Planckian blackbody at any temperature) and the 24 Macbeth
//! ColorChecker reflectances of N. Ohta (1997).
//!
//! The published figures live in [`cie`] and [`macbeth`]; they were generated at development time
//! from the `colour-science` Python package (0.4.7), each table naming its published source.

pub mod cie;
pub mod lamps;
pub mod macbeth;

use crate::error::{CoreError, Result};
use crate::grid::WavelengthGrid;
use crate::spectrum::{Extrapolation, Spectrum};
use crate::units::planck_radiance_w_per_sr_m2_nm;

/// Names accepted by [`illuminant`] (case-insensitive). `blackbody-<K>` takes any temperature in
/// kelvin between [`BLACKBODY_MIN_K`] and [`BLACKBODY_MAX_K`], e.g. `blackbody-5000`.
pub const ILLUMINANT_NAMES: &[&str] = &[
    "D65",
    "A",
    "C",
    "F2",
    "F11",
    "E",
    "blackbody-<K>",
    "HP1",
    "HP2",
    "HP3",
    "HP4",
    "HP5",
    "LED-B1",
    "LED-B2",
    "LED-B3",
    "LED-B4",
    "LED-B5",
    "LED-BH1",
    "LED-RGB1",
    "LED-V1",
    "LED-V2",
    "LPS",
];

/// Lowest blackbody temperature [`illuminant`] accepts, K.
pub const BLACKBODY_MIN_K: f64 = 100.0;
/// Highest blackbody temperature [`illuminant`] accepts, K.
pub const BLACKBODY_MAX_K: f64 = 1.0e6;

/// Wavelength at which CIE relative SPDs (and [`blackbody`]) are normalised, nm.
pub const NORMALIZATION_WAVELENGTH_NM: f64 = 560.0;

/// Patch names of the Macbeth ColorChecker in chart order, row by row from the top left
/// (1 dark skin ... 24 black), as named by McCamy, Marcus & Davidson (1976). The neutral series
/// 19-24 are "white 9.5 (.05 D)" ... "black 2 (1.5 D)" in full (see [`macbeth::NAMES`]).
pub const MACBETH_PATCH_NAMES: [&str; 24] = [
    "dark skin",
    "light skin",
    "blue sky",
    "foliage",
    "blue flower",
    "bluish green",
    "orange",
    "purplish blue",
    "moderate red",
    "purple",
    "yellow green",
    "orange yellow",
    "blue",
    "green",
    "red",
    "yellow",
    "magenta",
    "cyan",
    "white",
    "neutral 8",
    "neutral 6.5",
    "neutral 5",
    "neutral 3.5",
    "black",
];

/// The grid of every 5-nm table here that starts at `start_nm`.
fn table_spectrum(start_nm: f64, step_nm: f64, values: &[f64]) -> Spectrum {
    let wavelengths_nm = (0..values.len())
        .map(|i| start_nm + step_nm * i as f64)
        .collect();
    Spectrum {
        wavelengths_nm,
        values: values.to_vec(),
        extrapolation: Extrapolation::Zero,
    }
}

/// The CIE 1931 2-degree standard observer colour-matching functions [x-bar, y-bar, z-bar],
/// 360-830 nm every 5 nm (CIE 015:2018; see [`cie::CIE1931_X_BAR`]). Zero outside that range.
pub fn cie1931_xyz_cmfs() -> [Spectrum; 3] {
    [
        table_spectrum(cie::CMF_START_NM, cie::CMF_STEP_NM, &cie::CIE1931_X_BAR),
        table_spectrum(cie::CMF_START_NM, cie::CMF_STEP_NM, &cie::CIE1931_Y_BAR),
        table_spectrum(cie::CMF_START_NM, cie::CMF_STEP_NM, &cie::CIE1931_Z_BAR),
    ]
}

/// The wavelength range used for the computed illuminants (E, blackbody) returned by
/// [`illuminant`]: 300-830 nm every 5 nm, covering every built-in table.
pub fn computed_illuminant_grid() -> WavelengthGrid {
    WavelengthGrid {
        start_nm: 300.0,
        step_nm: 5.0,
        count: 107,
    }
}

/// A CIE or computed illuminant by name (case-insensitive):
///
/// - `D65`, `A`: CIE relative SPDs as published, 100 at 560 nm, 300-780 nm every 5 nm.
/// - `C`: CIE illuminant C as published (105.3 at 560 nm), 300-780 nm every 5 nm.
/// - `F2`, `F11` (also `FL2`, `FL11`): CIE fluorescent SPDs in their published relative units
///   (not normalised at 560 nm), 380-780 nm every 5 nm.
/// - `E`: equal energy, 100 at every wavelength of 300-830 nm (CIE 015:2018).
/// - `blackbody-<K>` (e.g. `blackbody-5000`, `blackbody-6500K`): Planck's law at that temperature,
///   scaled to 100 at 560 nm like the CIE tables, 300-830 nm every 5 nm.
/// - CIE 015:2018 Table 10's lamps by their CIE names (`HP1` ... `HP5`, `LED-B1` ... `LED-V2`).
/// - `LPS` (also `low-pressure-sodium`): a low-pressure sodium lamp as its D doublet
///   ([`low_pressure_sodium`]), 1000 relative units in all.
///
/// All are zero outside their range. Units are relative; scenes scale them to a luminance.
pub fn illuminant(name: &str) -> Result<Spectrum> {
    let key = name.trim().to_ascii_lowercase();
    let s = match key.as_str() {
        "d65" => table_spectrum(cie::D65_START_NM, 5.0, &cie::D65),
        "a" => table_spectrum(cie::A_START_NM, 5.0, &cie::A),
        "c" => table_spectrum(cie::C_START_NM, 5.0, &cie::C),
        "f2" | "fl2" => table_spectrum(cie::F2_START_NM, 5.0, &cie::F2),
        "f11" | "fl11" => table_spectrum(cie::F11_START_NM, 5.0, &cie::F11),
        "e" => Spectrum::constant(&computed_illuminant_grid(), 100.0),
        // CIE 015:2018 Table 10's discharge lamps and LEDs (night scenes: street lamps, headlamps).
        k if lamps::LAMPS.iter().any(|l| l.0.eq_ignore_ascii_case(k)) => {
            let (_, _, v) = lamps::LAMPS
                .iter()
                .find(|l| l.0.eq_ignore_ascii_case(k))
                .expect("just found");
            table_spectrum(lamps::START_NM, lamps::STEP_NM, v)
        }
        "lps" | "low-pressure-sodium" => low_pressure_sodium(),
        _ => {
            if let Some(t) = key
                .strip_prefix("blackbody-")
                .or_else(|| key.strip_prefix("blackbody"))
            {
                let t = t.trim().trim_end_matches('k').trim();
                let temperature_k: f64 = t.parse().map_err(|_| {
                    CoreError::invalid(
                        format!("illuminant '{name}'"),
                        format!("'{t}' is not a temperature in kelvin; write e.g. blackbody-5000"),
                    )
                })?;
                if !(BLACKBODY_MIN_K..=BLACKBODY_MAX_K).contains(&temperature_k) {
                    return Err(CoreError::invalid(
                        format!("illuminant '{name}'"),
                        format!(
                            "blackbody temperature {temperature_k} K is outside {BLACKBODY_MIN_K}-{BLACKBODY_MAX_K} K"
                        ),
                    ));
                }
                blackbody(temperature_k, &computed_illuminant_grid()).scaled(100.0)
            } else {
                return Err(CoreError::invalid(
                    format!("illuminant '{name}'"),
                    format!(
                        "unknown illuminant; known names: {}",
                        ILLUMINANT_NAMES.join(", ")
                    ),
                ));
            }
        }
    };
    Ok(s)
}

/// Half-width of the triangle [`line_spectrum`] draws each emission line as, nm.
pub const LINE_HALF_WIDTH_NM: f64 = 10.0;

/// A spectrum of emission lines, `(wavelength nm, power)` each, drawn as triangles of half-width
/// [`LINE_HALF_WIDTH_NM`] centred on the lines (values in power per nm). camsim samples spectra
/// at its grid's wavelengths, which would miss a line narrower than the grid's step; a triangle
/// of half-width h sampled at any step h / k (10, 5, 2.5, 2, 1 nm ...), at any offset, gives
/// samples whose sum times the step is the line's power and whose centroid is the line's
/// wavelength (the triangle's Fourier transform, h sinc^2(f h), and its derivative vanish at every
/// multiple 1/h of the sampling frequency 1/step: Poisson summation). On the 10-nm grid a line is
/// shared between its two neighbouring wavelengths as linear interpolation shares a point; a grid
/// coarser than 10 nm loses that exactness.
pub fn line_spectrum(lines: &[(f64, f64)]) -> Spectrum {
    let h = LINE_HALF_WIDTH_NM;
    let mut knots: Vec<f64> = lines.iter().flat_map(|&(c, _)| [c - h, c, c + h]).collect();
    knots.sort_by(f64::total_cmp);
    knots.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    let values = knots
        .iter()
        .map(|&x| {
            lines
                .iter()
                .map(|&(c, p)| p / h * (1.0 - (x - c).abs() / h).max(0.0))
                .sum()
        })
        .collect();
    Spectrum {
        wavelengths_nm: knots,
        values,
        extrapolation: Extrapolation::Zero,
    }
}

/// Sodium's D lines, nm in air (NIST Atomic Spectra Database, Na I: D2 588.9950, D1 589.5924).
pub const SODIUM_D_NM: [f64; 2] = [588.995, 589.592];

/// A low-pressure sodium (SOX) lamp: the sodium D doublet, D2 : D1 = 2 : 1 (the optically thin
/// ratio of g_k A_ki, 4 x 6.16e7 : 2 x 6.14e7 s^-1, NIST ASD), 1000 relative units in all, as a
/// [`line_spectrum`]. Left out: the lamp's weak sodium lines (568.3/568.8, 615.4/616.1, 498 nm:
/// a few per cent of its light) and its neon glow while warming up; self-absorption in a real
/// lamp evens the doublet's ratio, which moves nothing on grids of 10 nm or finer (both lines lie
/// 0.6 nm apart).
pub fn low_pressure_sodium() -> Spectrum {
    line_spectrum(&[
        (SODIUM_D_NM[0], 2000.0 / 3.0),
        (SODIUM_D_NM[1], 1000.0 / 3.0),
    ])
}

/// Planckian (blackbody) relative spectral radiance at `temperature_k` on `grid`, 1 at 560 nm
/// (Planck's law, [`planck_radiance_w_per_sr_m2_nm`]; CIE 015:2018 uses the same form with
/// c2 = 1.4388e-2 m K). When Planck's law underflows (low temperatures) the ratio is taken in log
/// space, so values are finite for every temperature >= [`BLACKBODY_MIN_K`] on grids below 5000 nm
/// (far below that, the ratio to 560 nm exceeds f64 and becomes +inf; never NaN). A temperature that is not a finite positive number
/// gives all zeros ([`illuminant`] checks temperatures and names the bad one).
pub fn blackbody(temperature_k: f64, grid: &WavelengthGrid) -> Spectrum {
    if !(temperature_k.is_finite() && temperature_k > 0.0) {
        return Spectrum::constant(grid, 0.0);
    }
    let l0 = NORMALIZATION_WAVELENGTH_NM;
    let b0 = planck_radiance_w_per_sr_m2_nm(l0, temperature_k);
    let values = (0..grid.len())
        .map(|i| {
            let l = grid.wavelength_nm(i);
            let b = planck_radiance_w_per_sr_m2_nm(l, temperature_k);
            if b0.is_normal() && b.is_finite() && b > 0.0 {
                b / b0
            } else {
                // B(l)/B(l0) = (l0/l)^5 * (exp(c2/(l0 T)) - 1) / (exp(c2/(l T)) - 1); for large
                // exponents the -1 terms vanish: (l0/l)^5 * exp(c2/(l0 T) - c2/(l T)).
                let c2_nm_k = crate::units::PLANCK_J_S * crate::units::SPEED_OF_LIGHT_M_PER_S
                    / crate::units::BOLTZMANN_J_PER_K
                    * 1e9;
                let a0 = c2_nm_k / (l0 * temperature_k);
                let a = c2_nm_k / (l * temperature_k);
                let ln_ratio = 5.0 * (l0 / l).ln() + ln_expm1(a0) - ln_expm1(a);
                ln_ratio.exp()
            }
        })
        .collect();
    Spectrum::on_grid(grid, values)
}

/// ln(exp(x) - 1) for x > 0 without overflow.
fn ln_expm1(x: f64) -> f64 {
    if x > 30.0 {
        x + (-(-x).exp()).ln_1p()
    } else {
        x.exp_m1().ln()
    }
}

/// The 24 Macbeth ColorChecker spectral reflectances (fraction) of N. Ohta (1997), 380-780 nm
/// every 5 nm, in chart order ([`MACBETH_PATCH_NAMES`]). Outside 380-780 nm they hold their end
/// values (a reflectance does not drop to zero just past the measured range).
pub fn macbeth_reflectances() -> Vec<Spectrum> {
    macbeth::REFLECTANCE
        .iter()
        .map(|r| {
            table_spectrum(macbeth::START_NM, macbeth::STEP_NM, r)
                .with_extrapolation(Extrapolation::Hold)
        })
        .collect()
}

/// One ColorChecker reflectance by chart number (`"1"` ... `"24"`) or name (case-insensitive;
/// the short names of [`MACBETH_PATCH_NAMES`] or the full ones of [`macbeth::NAMES`]).
pub fn macbeth_patch(name_or_number: &str) -> Result<Spectrum> {
    let key = name_or_number.trim().to_ascii_lowercase();
    let index = if let Ok(n) = key.parse::<usize>() {
        (1..=24).contains(&n).then(|| n - 1)
    } else {
        MACBETH_PATCH_NAMES
            .iter()
            .position(|n| *n == key)
            .or_else(|| {
                macbeth::NAMES
                    .iter()
                    .position(|n| n.to_ascii_lowercase() == key)
            })
    };
    match index {
        Some(i) => Ok(macbeth_reflectances().swap_remove(i)),
        None => Err(CoreError::invalid(
            format!("ColorChecker patch '{name_or_number}'"),
            format!(
                "use a number 1-24 or a name: {}",
                MACBETH_PATCH_NAMES.join(", ")
            ),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_lengths_match_their_ranges() {
        assert_eq!(cie::CIE1931_X_BAR.len(), (830 - 360) / 5 + 1);
        assert_eq!(cie::D65.len(), (780 - 300) / 5 + 1);
        assert_eq!(cie::F11.len(), (780 - 380) / 5 + 1);
        assert_eq!(computed_illuminant_grid().end_nm(), 830.0);
    }

    #[test]
    fn illuminant_names_are_case_insensitive_and_errors_list_names() {
        assert_eq!(illuminant("d65").unwrap(), illuminant("D65").unwrap());
        assert_eq!(illuminant("fl11").unwrap(), illuminant("F11").unwrap());
        let e = illuminant("D66").unwrap_err().to_string();
        assert!(
            e.contains("D66") && e.contains("F11") && e.contains("blackbody"),
            "{e}"
        );
        assert!(illuminant("blackbody-abc").is_err());
        assert!(illuminant("blackbody-0").is_err());
        assert!(illuminant("blackbody-nan").is_err());
        let bb = illuminant("Blackbody-5000K").unwrap();
        assert!((bb.eval(560.0) - 100.0).abs() < 1e-9);
    }

    #[test]
    fn blackbody_is_finite_at_extreme_temperatures() {
        let g = WavelengthGrid::new(300.0, 830.0, 5.0).unwrap();
        let cold = blackbody(1.0, &g);
        assert!(cold.values.iter().all(|v| !v.is_nan() && *v >= 0.0));
        assert!((cold.eval(560.0) - 1.0).abs() < 1e-9);
        for t in [BLACKBODY_MIN_K, 300.0, BLACKBODY_MAX_K] {
            let b = blackbody(t, &g);
            assert!(b.values.iter().all(|v| v.is_finite() && *v >= 0.0), "T={t}");
            assert!((b.eval(560.0) - 1.0).abs() < 1e-9, "T={t}");
        }
        // Continuity of the log-space branch: ratio computed both ways at moderate T agrees.
        let direct = blackbody(300.0, &g);
        let l = 400.0;
        let c2: f64 = 1.438_776_877e7; // nm K (CODATA 2018)
        let expect =
            (560.0f64 / l).powi(5) * (c2 / (560.0 * 300.0)).exp_m1() / (c2 / (l * 300.0)).exp_m1();
        assert!((direct.eval(l) / expect - 1.0).abs() < 1e-6);
    }

    #[test]
    fn macbeth_lookup() {
        assert_eq!(
            macbeth_patch("19").unwrap(),
            macbeth_patch("White").unwrap()
        );
        assert_eq!(
            macbeth_patch("white 9.5 (.05 D)").unwrap(),
            macbeth_reflectances()[18]
        );
        assert!(macbeth_patch("25").is_err());
        assert!(macbeth_patch("grey").is_err());
    }
}
