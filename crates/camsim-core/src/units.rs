//! Physical constants and conversions. SI inside; the unit is in every name.

/// Planck constant, J s (CODATA 2018, exact).
pub const PLANCK_J_S: f64 = 6.626_070_15e-34;
/// Speed of light in vacuum, m/s (exact).
pub const SPEED_OF_LIGHT_M_PER_S: f64 = 299_792_458.0;
/// Boltzmann constant, J/K (CODATA 2018, exact).
pub const BOLTZMANN_J_PER_K: f64 = 1.380_649e-23;
/// Maximum luminous efficacy for photopic vision, lm/W (CIE; ISETCam uses 683).
pub const LUMINOUS_EFFICACY_LM_PER_W: f64 = 683.0;

/// Energy of one photon of wavelength `wavelength_nm`, in joules: E = h c / lambda.
pub fn photon_energy_j(wavelength_nm: f64) -> f64 {
    PLANCK_J_S * SPEED_OF_LIGHT_M_PER_S / (wavelength_nm * 1e-9)
}

/// Energy quantity (W, or W per anything) -> photon quantity (photons/s per the same), lambda/(h c)
/// (ISETCam `Energy2Quanta`).
pub fn energy_to_photons(energy: f64, wavelength_nm: f64) -> f64 {
    energy / photon_energy_j(wavelength_nm)
}

/// Photon quantity -> energy quantity (ISETCam `Quanta2Energy`).
pub fn photons_to_energy(photons: f64, wavelength_nm: f64) -> f64 {
    photons * photon_energy_j(wavelength_nm)
}

/// Blackbody spectral radiance (Planck's law) in W/(sr m^2 nm) at `wavelength_nm` and `temperature_k`.
pub fn planck_radiance_w_per_sr_m2_nm(wavelength_nm: f64, temperature_k: f64) -> f64 {
    let lambda_m = wavelength_nm * 1e-9;
    let h = PLANCK_J_S;
    let c = SPEED_OF_LIGHT_M_PER_S;
    let k = BOLTZMANN_J_PER_K;
    // B = 2 h c^2 / lambda^5 / (exp(h c / (lambda k T)) - 1)   [W / (sr m^2 m)]
    let b_per_m =
        2.0 * h * c * c / lambda_m.powi(5) / ((h * c / (lambda_m * k * temperature_k)).exp_m1());
    b_per_m * 1e-9
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn photon_energy_at_550_nm() {
        // h c / 550 nm = 3.6117e-19 J (textbook value).
        assert!((photon_energy_j(550.0) / 3.6117e-19 - 1.0).abs() < 1e-4);
        assert!((photons_to_energy(energy_to_photons(2.5, 480.0), 480.0) - 2.5).abs() < 1e-12);
    }

    #[test]
    fn planck_peak_follows_wien() {
        // Wien's displacement law: lambda_max T = 2.897771955e-3 m K.
        for t in [3000.0, 5000.0, 6500.0] {
            let peak = (2000..20000)
                .map(|i| i as f64 * 0.1)
                .max_by(|a, b| {
                    planck_radiance_w_per_sr_m2_nm(*a, t)
                        .total_cmp(&planck_radiance_w_per_sr_m2_nm(*b, t))
                })
                .unwrap();
            let wien_nm = 2.897_771_955e-3 / t * 1e9;
            assert!(
                (peak - wien_nm).abs() < 0.2,
                "T={t}: peak {peak} vs Wien {wien_nm}"
            );
        }
    }
}
