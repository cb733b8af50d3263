//! glTF's physical units turned into camsim's spectra (glTF 2.0 sec. 3.9 and Appendix B,
//! `KHR_materials_emissive_strength`, `KHR_lights_punctual`).
//!
//! | glTF quantity | unit | camsim |
//! |---|---|---|
//! | colours (base, emissive, light) | linear Rec. 709 primaries, D65 white | uplifted spectra |
//! | `emissiveFactor` x `emissiveStrength` | cd/m^2 (luminance) | area-light radiance, W/(sr m^2 nm) |
//! | point and spot `intensity` | cd (luminous intensity) | intensity, W/(sr nm) |
//! | directional `intensity` | lux (illuminance) | irradiance, W/(m^2 nm) |
//! | lengths | m | m |
//!
//! A colour `c` of luminance `Y(c) = 0.2126 R + 0.7152 G + 0.0722 B` times a photometric value
//! `v` becomes the spectrum `2 m S(c / 2m)(lambda) D65(lambda)` (`m` the largest component;
//! pbrt-v4's `RGBIlluminantSpectrum`, Jakob & Hanika 2019 uplift), scaled so that
//! `683 lm/W * int y_bar(lambda) s(lambda) dlambda = Y(c) v` exactly: a white emitter of
//! strength 100 renders 100 cd/m^2, a point light of I cd gives I / d^2 lux at d metres.

use camsim_core::spectrum::Extrapolation;
use camsim_core::units::LUMINOUS_EFFICACY_LM_PER_W;
use camsim_core::{tables, Spectrum};
use camsim_scene3d::spectra::photometric;
use camsim_scene3d::uplift;

/// Rec. 709 luminance of a linear RGB colour (ITU-R BT.709 coefficients).
pub fn rec709_luminance(rgb: [f64; 3]) -> f64 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

/// The relative spectrum of a linear-RGB light colour: `2 m S(c / 2m) D65` (see the module
/// docs); `None` for a black or negative colour.
pub fn illuminant_shape(rgb: [f64; 3]) -> Option<Spectrum> {
    let m = rgb[0].max(rgb[1]).max(rgb[2]);
    if !(m > 0.0) || rgb.iter().any(|v| *v < 0.0 || !v.is_finite()) {
        return None;
    }
    let scale = 2.0 * m;
    let base = uplift::rgb_to_reflectance_full(rgb.map(|v| (v / scale) as f32)).scaled(scale);
    let d65 = tables::illuminant("D65").expect("built-in D65");
    let pairs: Vec<(f64, f64)> = base
        .wavelengths_nm
        .iter()
        .zip(&base.values)
        .map(|(&l, &v)| (l, v * d65.eval(l)))
        .collect();
    Some(Spectrum::from_pairs(&pairs).with_extrapolation(Extrapolation::Zero))
}

/// A spectrum of the colour `rgb` whose photometric value (`683 int y_bar s`) is `Y(rgb) *
/// value` (cd/m^2 for a radiance, cd for an intensity, lux for an irradiance). Black (or a zero
/// value) gives `None`.
pub fn photometric_spectrum(rgb: [f64; 3], value: f64) -> Option<Spectrum> {
    let target = rec709_luminance(rgb) * value;
    if !(target > 0.0 && target.is_finite()) {
        return None;
    }
    let shape = illuminant_shape(rgb)?;
    let p = photometric(&shape);
    if !(p > 0.0) {
        return None;
    }
    Some(shape.scaled(target / (LUMINOUS_EFFICACY_LM_PER_W * p)))
}

/// The D65 spectrum of luminance 1 cd/m^2 for the RGB colour (1, 1, 1): the per-unit-RGB
/// illuminant of an emission image (`AreaLight::image` multiplies it by each texel's
/// uplifted colour).
pub fn unit_rgb_illuminant() -> Spectrum {
    photometric_spectrum([1.0; 3], 1.0).expect("white has a luminance")
}

/// A linear-RGB reflectance (clamped to [0, 1]) as camsim's uplifted reflectance spectrum.
pub fn reflectance(rgb: [f64; 3]) -> Spectrum {
    uplift::rgb_to_reflectance_full(rgb.map(|v| v.clamp(0.0, 1.0) as f32))
        .with_extrapolation(Extrapolation::Hold)
}

/// A linear-RGB factor that may exceed 1 (`specularColorFactor`): `2 m S(c / 2m)` (pbrt-v4
/// `RGBUnboundedSpectrum`).
pub fn unbounded(rgb: [f64; 3]) -> Spectrum {
    let m = rgb[0].max(rgb[1]).max(rgb[2]).max(0.0);
    if m <= 1.0 {
        return reflectance(rgb);
    }
    let scale = 2.0 * m;
    uplift::rgb_to_reflectance_full(rgb.map(|v| (v.max(0.0) / scale) as f32))
        .scaled(scale)
        .with_extrapolation(Extrapolation::Hold)
}

/// The sRGB electro-optical transfer function (IEC 61966-2-1): an 8-bit-style code value in
/// [0, 1] to linear.
#[inline]
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_emitter_has_the_files_luminance() {
        let s = photometric_spectrum([1.0, 1.0, 1.0], 100.0).unwrap();
        let l = LUMINOUS_EFFICACY_LM_PER_W * photometric(&s);
        assert!((l - 100.0).abs() < 1e-9, "{l}");
        // A coloured emitter keeps Y(rgb) times the strength.
        let s = photometric_spectrum([1.0, 0.2, 0.1], 12.0).unwrap();
        let l = LUMINOUS_EFFICACY_LM_PER_W * photometric(&s);
        let want = 12.0 * rec709_luminance([1.0, 0.2, 0.1]);
        assert!((l - want).abs() < 1e-9 * want, "{l} vs {want}");
        assert!(photometric_spectrum([0.0; 3], 5.0).is_none());
    }

    #[test]
    fn srgb_curve_matches_iec_61966_points() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        // 0.5 -> 0.214041 (IEC 61966-2-1 curve).
        assert!((srgb_to_linear(0.5) - 0.214_041).abs() < 1e-5);
    }
}
