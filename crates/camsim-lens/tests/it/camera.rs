//! The renderer-facing lens camera: focus, rays from the film out through the lens, exit-pupil
//! bounds, and the relative illumination of a traced prescription in the thin-lens limit.

use camsim_lens::{Lens, LensCamera, Medium, Surface};
use std::path::Path;

const LENS_DIR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/data/isetcornellbox/lens"
);

#[test]
fn focused_at_infinity_a_film_point_leaves_as_a_parallel_beam() {
    let lens = Lens::from_file(&Path::new(LENS_DIR).join("dgauss.82deg.4.38mm.json"))
        .unwrap()
        .with_stop_semi_aperture_mm(0.4);
    let p = lens.paraxial(550.0);
    let cam = LensCamera::focused(lens, f64::INFINITY, 2.0).unwrap();
    assert!(
        (cam.film_distance_mm - p.bfd_mm).abs() < 1e-3 * p.efl_mm,
        "{} vs {}",
        cam.film_distance_mm,
        p.bfd_mm
    );
    // From a film point near the axis, every passing ray leaves at the same angle, tan = h / f.
    let h = 0.02;
    let b = cam.exit_pupil_bounds(h);
    let mut slopes = Vec::new();
    for i in 0..9 {
        for j in 0..9 {
            let x = b[0] + (b[1] - b[0]) * (i as f64 + 0.5) / 9.0;
            let y = b[2] + (b[3] - b[2]) * (j as f64 + 0.5) / 9.0;
            if let Some(r) = cam.trace_ray([h, 0.0], [x - h, y, -cam.film_distance_mm], 550.0) {
                slopes.push(r.direction[0] / r.direction[2]);
            }
        }
    }
    assert!(slopes.len() > 20, "{} rays passed", slopes.len());
    let (lo, hi) = slopes
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |a, s| {
            (a.0.min(*s), a.1.max(*s))
        });
    println!(
        "{} rays; slope {lo:.6} .. {hi:.6}; h / f = {:.6}",
        slopes.len(),
        h / p.efl_mm
    );
    // Parallel within the lens's residual aberration: 1 mrad, a 4 um blur at f = 4.38 mm.
    assert!(hi - lo < 1e-3, "not collimated: {lo} .. {hi}");
    assert!(((lo + hi) / 2.0 / (h / p.efl_mm) - 1.0).abs() < 0.02);
    // Outside the bounds nothing passes.
    for (x, y) in [(b[1] + 0.05, 0.0), (b[0] - 0.05, 0.0), (0.0, b[3] + 0.05)] {
        assert!(cam
            .trace_ray([h, 0.0], [x - h, y, -cam.film_distance_mm], 550.0)
            .is_none());
    }
}

/// A thin plano-convex singlet (f = 20 mm) with a small stop in contact: the relative
/// illumination of the traced lens tends to cos^4 of the chief-ray angle.
#[test]
fn traced_relative_illumination_approaches_cos4_for_a_thin_lens() {
    let surf =
        |radius_mm: f64, thickness_mm: f64, medium: Medium, semi: f64, is_stop: bool| Surface {
            radius_mm,
            thickness_mm,
            medium,
            semi_aperture_mm: semi,
            conic: 0.0,
            aspheric: vec![],
            is_stop,
        };
    let lens = Lens {
        name: "thin".into(),
        surfaces: vec![
            surf(0.0, 0.0, Medium::constant(1.0), 0.25, true),
            surf(10.3, 0.1, Medium::constant(1.5168), 1.2, false),
            surf(0.0, 0.0, Medium::constant(1.0), 1.2, false),
        ],
    };
    lens.check("thin").unwrap();
    let cam = LensCamera::focused(lens, f64::INFINITY, 16.0).unwrap();
    let heights = [0.0, 2.0, 4.0, 6.0, 8.0];
    let ri = cam.relative_illumination(&heights, 120, 550.0);
    for (h, r) in heights.iter().zip(&ri) {
        let cos = (cam.film_distance_mm / (h * h + cam.film_distance_mm.powi(2)).sqrt()).powi(4);
        println!("h {h} mm: RI {r:.4}, cos^4 {cos:.4}");
        assert!((r - cos).abs() < 0.01, "h {h}: {r} vs {cos}");
    }
}
