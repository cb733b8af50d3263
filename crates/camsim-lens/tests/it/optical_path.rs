//! `Lens::trace_forward_path`: the optical path through a plane-parallel plate against its closed
//! form, and the stop-plane crossing.

use camsim_lens::{Lens, Medium, Ray, Surface};

/// Air gap then a glass plate: OPL = sum n_i t_i / cos(theta_i), with Snell's law
/// sin(theta_glass) = sin(theta) / n (Born & Wolf sec. 3.3.1, optical path).
#[test]
fn plate_optical_path_matches_the_closed_form() {
    let n_glass = 1.5;
    let surf = |thickness_mm: f64, medium: Medium, is_stop: bool| Surface {
        radius_mm: 0.0,
        thickness_mm,
        medium,
        semi_aperture_mm: 5.0,
        conic: 0.0,
        aspheric: vec![],
        is_stop,
    };
    let lens = Lens {
        name: "plate".into(),
        surfaces: vec![
            surf(0.1, Medium::constant(1.0), true),
            surf(2.0, Medium::constant(n_glass), false),
            surf(0.0, Medium::constant(1.0), false),
        ],
    };
    for theta_deg in [0.0f64, 10.0, 30.0] {
        let th = theta_deg.to_radians();
        let ray = Ray::new([0.0, 0.0, -1.0], [th.sin(), 0.0, th.cos()]);
        let p = lens.trace_forward_path(&ray, 550.0).unwrap();
        let th_g = (th.sin() / n_glass).asin();
        let want = 1.1 / th.cos() + n_glass * 2.0 / th_g.cos();
        println!(
            "{theta_deg} deg: OPL {:.12} mm (closed form {want:.12})",
            p.optical_path_mm
        );
        assert!(
            (p.optical_path_mm - want).abs() < 1e-12,
            "{theta_deg}: {} vs {want}",
            p.optical_path_mm
        );
        assert!((p.stop_point_mm[0] - th.tan()).abs() < 1e-12 && p.stop_point_mm[2].abs() < 1e-12);
        // The ray leaves parallel to how it came in (a plate does not deviate).
        assert!((p.ray.direction[0] - th.sin()).abs() < 1e-12);
    }
}
