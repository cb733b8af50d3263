//! Small numerical helpers shared by the stages.

/// The normalized sinc, sin(pi x) / (pi x), with sinc(0) = 1: the transfer function of a box
/// (pixel aperture) of unit width at frequency x (Goodman, Introduction to Fourier Optics, 2.1).
pub fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        1.0
    } else {
        let a = std::f64::consts::PI * x;
        a.sin() / a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sinc_values() {
        assert_eq!(sinc(0.0), 1.0);
        for k in 1..5 {
            assert!(sinc(k as f64).abs() < 1e-15);
        }
        assert!((sinc(0.5) - 2.0 / std::f64::consts::PI).abs() < 1e-15);
    }
}
