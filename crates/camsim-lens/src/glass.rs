//! Refractive index of the media between surfaces: a constant, or a dispersive glass given by its
//! d-line index and Abbe number.

/// Fraunhofer d (He, 587.56 nm), F (H, 486.13 nm) and C (H, 656.27 nm) lines, nm
/// (the wavelengths of the Abbe number V_d = (n_d - 1) / (n_F - n_C); ISO 7944).
pub const D_LINE_NM: f64 = 587.56;
/// F line, nm.
pub const F_LINE_NM: f64 = 486.13;
/// C line, nm.
pub const C_LINE_NM: f64 = 656.27;

/// The medium after a surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Medium {
    /// The same index at every wavelength (0 in a file means air, stored as 1).
    Constant(f64),
    /// Two-term Cauchy dispersion n(lambda) = a + b / lambda^2 (lambda in um) through n_d at the
    /// d line with n_F - n_C = (n_d - 1) / V_d (Cauchy's formula; Hecht, Optics, 5th ed., sec.
    /// 3.5.1; fitting it to n_d and V_d is the usual two-parameter glass model).
    Cauchy {
        /// Index at the d line.
        nd: f64,
        /// Abbe number V_d.
        vd: f64,
        /// a (dimensionless).
        a: f64,
        /// b, um^2.
        b: f64,
    },
}

impl Medium {
    /// A constant index; 0 (the files' "air") becomes 1.
    pub fn constant(n: f64) -> Medium {
        Medium::Constant(if n == 0.0 { 1.0 } else { n })
    }

    /// A dispersive glass from n_d and the Abbe number V_d (> 0).
    pub fn from_abbe(nd: f64, vd: f64) -> std::result::Result<Medium, String> {
        if !(vd.is_finite() && vd > 0.0) {
            return Err(format!("abbe_number {vd} is not a number > 0"));
        }
        if !(nd.is_finite() && nd >= 1.0) {
            return Err(format!("ior {nd} must be >= 1 for a dispersive glass"));
        }
        let inv2 = |nm: f64| 1.0 / (nm * 1e-3 * nm * 1e-3);
        let b = (nd - 1.0) / vd / (inv2(F_LINE_NM) - inv2(C_LINE_NM));
        let a = nd - b * inv2(D_LINE_NM);
        Ok(Medium::Cauchy { nd, vd, a, b })
    }

    /// Refractive index at `wavelength_nm`.
    pub fn index(&self, wavelength_nm: f64) -> f64 {
        match *self {
            Medium::Constant(n) => n,
            Medium::Cauchy { a, b, .. } => {
                let l_um = wavelength_nm * 1e-3;
                a + b / (l_um * l_um)
            }
        }
    }

    /// Error message when the index is impossible.
    pub fn check(&self) -> std::result::Result<(), String> {
        let n = match *self {
            Medium::Constant(n) => n,
            Medium::Cauchy { nd, .. } => nd,
        };
        if !n.is_finite() {
            return Err(format!("ior is {n}, not a finite number"));
        }
        if n < 1.0 {
            return Err(format!("ior {n} is below 1 (0 means air)"));
        }
        Ok(())
    }
}
