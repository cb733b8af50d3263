//! Named spectra of optical constants that pbrt-v4 scenes refer to by name: metals' complex
//! index of refraction (`metal-Cu-eta`, `metal-Cu-k`, ...) and glass dispersion (`glass-BK7`).
//!
//! Data (published measurements, tabulated at their own wavelengths over the visible range, a
//! little beyond 360-830 nm; the renderer interpolates linearly and holds the end values):
//! - Cu, Ag, Au: P. B. Johnson and R. W. Christy, "Optical constants of the noble metals",
//!   Phys. Rev. B 6, 4370-4379 (1972), as tabulated by the refractiveindex.info database
//!   (`main/{Cu,Ag,Au}/Johnson`).
//! - Al: A. D. Rakic, "Algorithm for the determination of intrinsic optical constants of metal
//!   films: application to aluminum", Appl. Opt. 34, 4755-4767 (1995), as tabulated by the
//!   refractiveindex.info database (`main/Al/Rakic`).
//! - BK7: Schott N-BK7 Sellmeier coefficients (Schott optical glass data sheet), evaluated every
//!   10 nm over 360-830 nm.

use camsim_core::Spectrum;

/// (wavelength um, n, k) rows.
type Nk = &'static [(f64, f64, f64)];

const CU_JOHNSON_CHRISTY: Nk = &[
    (0.3425, 1.36, 1.864),
    (0.3542, 1.37, 1.916),
    (0.3679, 1.36, 1.975),
    (0.3815, 1.33, 2.045),
    (0.3974, 1.32, 2.116),
    (0.4133, 1.28, 2.207),
    (0.4305, 1.25, 2.305),
    (0.4509, 1.24, 2.397),
    (0.4714, 1.25, 2.483),
    (0.4959, 1.22, 2.564),
    (0.5209, 1.18, 2.608),
    (0.5486, 1.02, 2.577),
    (0.5821, 0.70, 2.704),
    (0.6168, 0.30, 3.205),
    (0.6595, 0.22, 3.747),
    (0.7045, 0.21, 4.205),
    (0.7560, 0.24, 4.665),
    (0.8211, 0.26, 5.180),
    (0.8920, 0.30, 5.768),
];

const AG_JOHNSON_CHRISTY: Nk = &[
    (0.3425, 0.14, 1.142),
    (0.3542, 0.10, 1.419),
    (0.3679, 0.07, 1.657),
    (0.3815, 0.05, 1.864),
    (0.3974, 0.05, 2.070),
    (0.4133, 0.05, 2.275),
    (0.4305, 0.04, 2.462),
    (0.4509, 0.04, 2.657),
    (0.4714, 0.05, 2.869),
    (0.4959, 0.05, 3.093),
    (0.5209, 0.05, 3.324),
    (0.5486, 0.06, 3.586),
    (0.5821, 0.05, 3.858),
    (0.6168, 0.06, 4.152),
    (0.6595, 0.05, 4.483),
    (0.7045, 0.04, 4.838),
    (0.7560, 0.03, 5.242),
    (0.8211, 0.04, 5.727),
    (0.8920, 0.04, 6.312),
];

const AU_JOHNSON_CHRISTY: Nk = &[
    (0.3425, 1.48, 1.871),
    (0.3542, 1.50, 1.866),
    (0.3679, 1.48, 1.895),
    (0.3815, 1.46, 1.933),
    (0.3974, 1.47, 1.952),
    (0.4133, 1.46, 1.958),
    (0.4305, 1.45, 1.948),
    (0.4509, 1.38, 1.914),
    (0.4714, 1.31, 1.849),
    (0.4959, 1.04, 1.833),
    (0.5209, 0.62, 2.081),
    (0.5486, 0.43, 2.455),
    (0.5821, 0.29, 2.863),
    (0.6168, 0.21, 3.272),
    (0.6595, 0.14, 3.697),
    (0.7045, 0.13, 4.103),
    (0.7560, 0.14, 4.542),
    (0.8211, 0.16, 5.083),
    (0.8920, 0.17, 5.663),
];

const AL_RAKIC: Nk = &[
    (0.32628, 0.31474, 3.9165),
    (0.36466, 0.39877, 4.3957),
    (0.41328, 0.52135, 5.0008),
    (0.44280, 0.60790, 5.3676),
    (0.47687, 0.72780, 5.7781),
    (0.51660, 0.87340, 6.2418),
    (0.56357, 1.0728, 6.7839),
    (0.61993, 1.3660, 7.4052),
    (0.65225, 1.5724, 7.7354),
    (0.68881, 1.8301, 8.0601),
    (0.72932, 2.1606, 8.3565),
    (0.77491, 2.6154, 8.4914),
    (0.79478, 2.7675, 8.3866),
    (0.81569, 2.7668, 8.2573),
    (0.83774, 2.6945, 8.1878),
    (0.88561, 2.2802, 8.1134),
];

/// Schott N-BK7 Sellmeier coefficients: n^2 - 1 = sum B_i l^2 / (l^2 - C_i), l in um, C in um^2.
const BK7_SELLMEIER: ([f64; 3], [f64; 3]) = (
    [1.039_612_12, 0.231_792_344, 1.010_469_45],
    [0.006_000_698_67, 0.020_017_914_4, 103.560_653],
);

/// Refractive index from Sellmeier coefficients at `wavelength_nm`.
pub fn sellmeier_index((b, c): ([f64; 3], [f64; 3]), wavelength_nm: f64) -> f64 {
    let l2 = (wavelength_nm * 1e-3) * (wavelength_nm * 1e-3);
    (1.0 + (0..3).map(|i| b[i] * l2 / (l2 - c[i])).sum::<f64>()).sqrt()
}

/// Names this module provides.
pub const NAMES: &[&str] = &[
    "metal-Cu-eta",
    "metal-Cu-k",
    "metal-Ag-eta",
    "metal-Ag-k",
    "metal-Au-eta",
    "metal-Au-k",
    "metal-Al-eta",
    "metal-Al-k",
    "glass-BK7",
];

fn column(rows: Nk, k: bool) -> Spectrum {
    let pairs: Vec<(f64, f64)> = rows
        .iter()
        .map(|&(um, n, kk)| (um * 1e3, if k { kk } else { n }))
        .collect();
    Spectrum::from_pairs(&pairs)
}

/// The named spectrum, if it is one of [`NAMES`].
pub fn named(name: &str) -> Option<Spectrum> {
    let s = match name {
        "metal-Cu-eta" => column(CU_JOHNSON_CHRISTY, false),
        "metal-Cu-k" => column(CU_JOHNSON_CHRISTY, true),
        "metal-Ag-eta" => column(AG_JOHNSON_CHRISTY, false),
        "metal-Ag-k" => column(AG_JOHNSON_CHRISTY, true),
        "metal-Au-eta" => column(AU_JOHNSON_CHRISTY, false),
        "metal-Au-k" => column(AU_JOHNSON_CHRISTY, true),
        "metal-Al-eta" => column(AL_RAKIC, false),
        "metal-Al-k" => column(AL_RAKIC, true),
        "glass-BK7" => {
            let pairs: Vec<(f64, f64)> = (36..=83)
                .map(|i| {
                    (
                        i as f64 * 10.0,
                        sellmeier_index(BK7_SELLMEIER, i as f64 * 10.0),
                    )
                })
                .collect();
            Spectrum::from_pairs(&pairs)
        }
        _ => return None,
    };
    Some(s.with_extrapolation(camsim_core::spectrum::Extrapolation::Hold))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Catalogue values: N-BK7 n_d = 1.5168 at 587.56 nm, n_F = 1.5224 at 486.13 nm, n_C =
    /// 1.5143 at 656.27 nm (Schott data sheet; 4 decimals).
    #[test]
    fn bk7_matches_catalogue_indices() {
        for (l, n) in [(587.56, 1.5168), (486.13, 1.5224), (656.27, 1.5143)] {
            let got = sellmeier_index(BK7_SELLMEIER, l);
            assert!((got - n).abs() < 1e-4, "{l} nm: {got} vs {n}");
        }
    }

    #[test]
    fn every_name_resolves_and_covers_the_visible() {
        for n in NAMES {
            let s = named(n).unwrap();
            assert!(s.wavelengths_nm[0] <= 360.0, "{n}");
            assert!(*s.wavelengths_nm.last().unwrap() >= 830.0, "{n}");
            assert!(s.values.iter().all(|v| *v > 0.0), "{n}");
        }
    }
}
