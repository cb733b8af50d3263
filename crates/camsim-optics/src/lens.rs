//! Closed-form lens relations: thin-lens imaging, irradiance from radiance, the diffraction-limited
//! OTF and the wavefront defocus that a focus error implies.

use std::f64::consts::PI;

/// Diffraction-limited MTF of a circular aperture (incoherent imaging):
/// `(2/pi)(acos s - s sqrt(1 - s^2))`, `s = f lambda N`, 0 for `s >= 1`
/// (Goodman, Introduction to Fourier Optics, 3rd ed., eq. 6-32; ISETCam `dlMTF`).
/// `freq_cyc_per_mm` is the spatial frequency in the sensor plane.
pub fn diffraction_mtf(freq_cyc_per_mm: f64, wavelength_nm: f64, f_number: f64) -> f64 {
    let s = (freq_cyc_per_mm * 1e3).abs() * wavelength_nm * 1e-9 * f_number;
    diffraction_mtf_normalized(s)
}

/// Diffraction-limited MTF at normalized frequency `s = f / f_cutoff` (f_cutoff = 1/(lambda N)).
pub fn diffraction_mtf_normalized(s: f64) -> f64 {
    let s = s.abs();
    if s >= 1.0 {
        0.0
    } else {
        (2.0 / PI) * (s.acos() - s * (1.0 - s * s).sqrt())
    }
}

/// Diffraction cutoff frequency 1/(lambda N) in cycles per mm.
pub fn cutoff_cyc_per_mm(wavelength_nm: f64, f_number: f64) -> f64 {
    1.0 / (wavelength_nm * 1e-6 * f_number)
}

/// Thin-lens image distance v = 1 / (1/f - 1/d) (Gaussian lens equation), m. An object at
/// infinity (or `object_distance_m` <= 0, "unknown") images at the focal length. `None` when the
/// object is at or inside the focal length (no real image).
pub fn image_distance_m(focal_length_m: f64, object_distance_m: f64) -> Option<f64> {
    if !(object_distance_m > 0.0) || object_distance_m.is_infinite() {
        return Some(focal_length_m);
    }
    if object_distance_m <= focal_length_m {
        return None;
    }
    Some(1.0 / (1.0 / focal_length_m - 1.0 / object_distance_m))
}

/// Lateral magnification |m| = v / d of a thin lens; 0 for an object at infinity or at an unknown
/// distance (ISETCam `oiCalculateIrradiance` uses 0 then).
pub fn magnification(focal_length_m: f64, object_distance_m: f64) -> f64 {
    if !(object_distance_m > 0.0) || object_distance_m.is_infinite() {
        return 0.0;
    }
    match image_distance_m(focal_length_m, object_distance_m) {
        Some(v) => v / object_distance_m,
        None => 0.0,
    }
}

/// Radiance -> on-axis sensor irradiance factor `pi T / (1 + 4 N^2 (1 + |m|)^2)`
/// (ISETCam `oiCalculateIrradiance`; camera equation, e.g. Kingslake). E = factor * L with L in
/// W/(sr m^2 nm) and E in W/(m^2 nm).
pub fn irradiance_factor(f_number: f64, magnification: f64, transmittance: f64) -> f64 {
    PI * transmittance / (1.0 + 4.0 * f_number * f_number * (1.0 + magnification.abs()).powi(2))
}

/// Seidel defocus coefficient W020 (m) of a focus error, in the sign convention of ISETCam's wvf
/// (positive diopters -> positive microns): with the sensor at `v_sensor = image_distance(focus)`
/// and the object imaged at `v_obj`, the converging wave's sag differs from the reference sphere
/// centred on the sensor by
///   W020 = (a^2 / 2) (1/v_obj - 1/v_sensor) = (a^2 / 2) (1/d_focus - 1/d_obj)
/// (paraxial sag difference; Goodman, Introduction to Fourier Optics, 3rd ed., sec. 6.4.1,
/// "focusing errors", W(x,y) = (1/2)(1/z_a - 1/z_i)(x^2 + y^2)), with a the lens pupil radius.
/// The second form follows from 1/v = 1/f - 1/d. Positive W020: the object lies beyond the
/// focus distance (it focuses in front of the sensor); negative: nearer than the focus distance.
/// Distances <= 0 or infinite mean infinity.
pub fn defocus_w020_m(pupil_radius_m: f64, focus_distance_m: f64, object_distance_m: f64) -> f64 {
    let inv = |d: f64| {
        if d > 0.0 && d.is_finite() {
            1.0 / d
        } else {
            0.0
        }
    };
    0.5 * pupil_radius_m * pupil_radius_m * (inv(focus_distance_m) - inv(object_distance_m))
}

/// OSA unit-RMS defocus coefficient c4 (same unit as `w020`) that has the Seidel defocus `w020`:
/// Z(2,0) = sqrt(3)(2 rho^2 - 1) has rho^2 coefficient 2 sqrt(3) c4, so c4 = W020 / (2 sqrt 3).
/// Equivalent to ISETCam `wvfDefocusDioptersToMicrons`: c4_um = D * d_mm^2 / (16 sqrt 3).
pub fn c4_from_w020(w020: f64) -> f64 {
    w020 / (2.0 * 3f64.sqrt())
}

/// Defocus c4 in micrometres over the lens pupil for an object at `object_distance_m` when the
/// lens is focused at `focus_distance_m` (thin lens; see [`defocus_w020_m`]).
pub fn defocus_c4_um(
    focal_length_m: f64,
    f_number: f64,
    focus_distance_m: f64,
    object_distance_m: f64,
) -> f64 {
    let a = focal_length_m / f_number / 2.0;
    c4_from_w020(defocus_w020_m(a, focus_distance_m, object_distance_m)) * 1e6
}

/// Geometric circle-of-confusion diameter (m) on a sensor at the image distance of
/// `focus_distance_m`: c = A |v_sensor - v_obj| / v_obj, A = f / N (similar triangles).
/// Equals 4 |W020| v_sensor / a, the transverse ray aberration of the defocus wavefront.
pub fn circle_of_confusion_m(
    focal_length_m: f64,
    f_number: f64,
    focus_distance_m: f64,
    object_distance_m: f64,
) -> Option<f64> {
    let vs = image_distance_m(focal_length_m, focus_distance_m)?;
    let vo = image_distance_m(focal_length_m, object_distance_m)?;
    Some(focal_length_m / f_number * (vs - vo).abs() / vo)
}

/// Scale an OSA defocus coefficient given over a measurement pupil of radius `r_meas` to the
/// coefficient over a smaller lens pupil of radius `r_lens`: the rho^2 term of
/// c4 sqrt(3)(2 (r/r_meas)^2 - 1) is 2 sqrt(3) c4 (r_lens/r_meas)^2 (r/r_lens)^2, so
/// c4_lens = c4 (r_lens / r_meas)^2 (piston aside; ISETCam wvf evaluates the polynomial this way).
pub fn rescale_defocus(c4: f64, r_meas: f64, r_lens: f64) -> f64 {
    c4 * (r_lens / r_meas).powi(2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diffraction_mtf_limits() {
        assert!((diffraction_mtf(0.0, 550.0, 2.0) - 1.0).abs() < 1e-15);
        assert_eq!(
            diffraction_mtf(cutoff_cyc_per_mm(550.0, 2.0), 550.0, 2.0),
            0.0
        );
        // At s = 0.5: (2/pi)(pi/3 - 0.5 sqrt(0.75)) = 0.39100 (tabulated, e.g. Goodman fig. 6.10).
        assert!((diffraction_mtf_normalized(0.5) - 0.391002).abs() < 1e-6);
    }

    #[test]
    fn thin_lens_relations_agree() {
        let (f, n) = (4.38e-3, 1.73);
        let c = circle_of_confusion_m(f, n, 0.3, 0.5).unwrap();
        let a = f / n / 2.0;
        let vs = image_distance_m(f, 0.3).unwrap();
        let w = defocus_w020_m(a, 0.3, 0.5);
        assert!((c - 4.0 * w.abs() * vs / a).abs() < 1e-12 * c.max(1e-9) + 1e-15);
        assert_eq!(image_distance_m(f, 0.004), None);
        assert_eq!(magnification(f, 0.0), 0.0);
    }
}
