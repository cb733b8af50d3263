//! Relative illumination of the Pixel 4a rear lens from its ray-transfer function (ISET/
//! isetcornellbox `pixel4a-rearcamera-ellipse-raytransfer.json`, Goossens et al. 2022) against the
//! lens maker's Zemax design (`zemax-relative-illumination.txt`, 555 nm).

use camsim_lens::rtf::{read_zemax_relative_illumination, Rtf};
use std::path::Path;

const LENS_DIR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/data/isetcornellbox/lens"
);

#[test]
fn rtf_relative_illumination_matches_zemax() {
    let rtf =
        Rtf::from_file(&Path::new(LENS_DIR).join("pixel4a-rearcamera-ellipse-raytransfer.json"))
            .unwrap();
    let zemax = read_zemax_relative_illumination(
        &Path::new(LENS_DIR).join("zemax-relative-illumination.txt"),
    )
    .unwrap();
    assert_eq!(zemax.len(), 21);
    let heights: Vec<f64> = zemax.iter().map(|r| r.height_mm).collect();
    let ri = rtf.relative_illumination(&heights, 400);
    println!("| image height (mm) | Zemax RI | RTF RI | difference | relative |");
    let mut worst_abs: f64 = 0.0;
    for (z, r) in zemax.iter().zip(&ri) {
        let r = r.expect("inside the RTF's table");
        let d = r - z.ri;
        worst_abs = worst_abs.max(d.abs());
        println!(
            "| {:.4} | {:.4} | {:.4} | {:+.4} | {:+.2} % |",
            z.height_mm,
            z.ri,
            r,
            d,
            100.0 * d / z.ri
        );
    }
    println!("largest |RTF - Zemax| = {worst_abs:.4}");
    assert!(worst_abs <= 0.02, "{worst_abs}");
    // Relative: <= 2 % out to 2.65 mm, <= 4 % beyond (measured 1.8 % and 3.9 %). The 2 % the issue
    // asks for at every height is out of reach of this file: its pass region is an f/3.44 pupil,
    // not the f/1.83 one Zemax integrates (next test).
    for (z, r) in zemax.iter().zip(&ri) {
        let rel = (r.unwrap() / z.ri - 1.0).abs();
        let bound = if z.height_mm <= 2.65 { 0.02 } else { 0.04 };
        assert!(
            rel <= bound,
            "{} mm: {:.2} % > {:.0} %",
            z.height_mm,
            100.0 * rel,
            100.0 * bound
        );
    }
}

/// The RTF's on-axis pass region against the Zemax design's aperture. Zemax's "Effective F/#" N
/// of a row is the f-number of an aberration-free cone with the same image irradiance, so its
/// projected solid angle is pi NA^2 = pi / (4 N^2) (Zemax OpticStudio manual, Relative
/// Illumination: RI = (N_axis / N)^2, which the file's rows obey to 1e-4). The RTF's on-axis
/// projected solid angle (its ellipse at 2.589 mm, radius 0.38 mm: sin theta = 0.145) is 28 % of
/// Zemax's (f/3.44 against f/1.83, the lens is sold as f/1.73): the ray data the RTF was fitted
/// to sampled a stopped-down pupil (or one of a different design trial), so the vignetting and
/// pupil aberrations it holds at the field's edge are those of a smaller aperture, and its
/// relative illumination cannot be expected to follow Zemax's closer than the few per cent seen.
#[test]
fn rtf_pass_region_is_an_f3_4_pupil_while_zemax_integrates_f1_83() {
    let rtf =
        Rtf::from_file(&Path::new(LENS_DIR).join("pixel4a-rearcamera-ellipse-raytransfer.json"))
            .unwrap();
    let zemax = read_zemax_relative_illumination(
        &Path::new(LENS_DIR).join("zemax-relative-illumination.txt"),
    )
    .unwrap();
    for z in &zemax {
        let implied = (zemax[0].effective_f_number / z.effective_f_number).powi(2);
        assert!(
            (implied / z.ri - 1.0).abs() < 1e-3,
            "{}: RI {} against (N0/N)^2 {implied}",
            z.height_mm,
            z.ri
        );
    }
    let omega_rtf_sr = rtf.irradiance(0.0, 400).unwrap();
    let n_rtf = 1.0 / (2.0 * (omega_rtf_sr / std::f64::consts::PI).sqrt());
    let omega_zemax_sr = std::f64::consts::PI / (4.0 * zemax[0].effective_f_number.powi(2));
    let ratio = omega_rtf_sr / omega_zemax_sr;
    println!(
        "on axis: RTF {omega_rtf_sr:.4} sr (f/{n_rtf:.2}), Zemax {omega_zemax_sr:.4} sr (f/{:.2}): ratio {ratio:.3}",
        zemax[0].effective_f_number
    );
    assert!((3.35..3.55).contains(&n_rtf), "{n_rtf}");
    assert!((0.27..0.30).contains(&ratio), "{ratio}");
}

/// [`Rtf::irradiance`] (midpoint rule over the pass ellipse, D^2 dA / rho^4) against a render of
/// a uniform white scene as ISET3d's RTF camera does it: points uniform over a square on the pass
/// plane (a quasi-random R2 sequence, Roberts 2018), a ray from the film point through each, the
/// ray kept when [`Rtf::trace`] passes it, weight cos^4(theta) A / (N D^2) (pbrt's
/// `RealisticCamera` weight for uniform sampling of a plane at distance D).
#[test]
fn rtf_irradiance_matches_a_render_through_trace() {
    let rtf =
        Rtf::from_file(&Path::new(LENS_DIR).join("pixel4a-rearcamera-ellipse-raytransfer.json"))
            .unwrap();
    let d = rtf.pass_plane_distance_mm;
    for h in [0.0, 1.75, 3.0] {
        let e = rtf.pass_ellipse(h).unwrap();
        let half = 1.2 * e.radii_mm[0].max(e.radii_mm[1]);
        let (cx, cy) = (e.center_mm[0], e.center_mm[1]);
        let n = 100_000;
        // R2 sequence: fractional parts of i (1/g, 1/g^2), g the plastic number.
        let g = 1.324_717_957_244_746f64;
        let (a1, a2) = (1.0 / g, 1.0 / (g * g));
        let mut sum = 0.0;
        for i in 0..n {
            let u = (0.5 + a1 * i as f64).fract();
            let v = (0.5 + a2 * i as f64).fract();
            let (x, y) = (cx + half * (2.0 * u - 1.0), cy + half * (2.0 * v - 1.0));
            let w = [x, y - h, d];
            let len = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
            let dir = [w[0] / len, w[1] / len, w[2] / len];
            if rtf.trace([0.0, h], dir).is_some() {
                sum += dir[2].powi(4);
            }
        }
        let render = sum * (2.0 * half).powi(2) / (n as f64 * d * d);
        let integral = rtf.irradiance(h, 400).unwrap();
        println!(
            "h {h} mm: render {render:.6} sr, integral {integral:.6} sr, ratio {:.5}",
            render / integral
        );
        assert!(
            (render / integral - 1.0).abs() < 2e-3,
            "{h}: {render} against {integral}"
        );
    }
}

#[test]
fn rtf_on_axis_point_leaves_collimated_and_the_focal_length_is_4_38_mm() {
    // A film point on the axis leaves as a parallel beam (the input plane is the focal plane).
    let rtf =
        Rtf::from_file(&Path::new(LENS_DIR).join("pixel4a-rearcamera-ellipse-raytransfer.json"))
            .unwrap();
    // The polynomial's constant term puts the axial ray 2.5 um off the axis: measure from it.
    let h0 = rtf.trace([0.0, 0.0], [0.0, 0.0, 1.0]).expect("passes").0[1];
    for dy in [0.02f64, 0.05, 0.1] {
        let d = [0.0, dy, (1.0 - dy * dy).sqrt()];
        let (p, dir) = rtf.trace([0.0, 0.0], d).expect("passes");
        // Abbe sine condition: beam height = f sin(theta) on the film side.
        let f = (p[1] - h0) / dy;
        println!(
            "dy {dy}: output height {:.4} mm, direction ({:.5}, {:.5}, {:.5}), f = (h - h0) / sin = {f:.4} mm",
            p[1], dir[0], dir[1], dir[2]
        );
        assert!(dir[1].abs() < 1e-3, "not collimated: {dir:?}");
        assert!((f / 4.38 - 1.0).abs() < 0.01, "{f}");
    }
    // Far outside the pass ellipse: vignetted.
    assert!(rtf.trace([0.0, 0.0], [0.0, 0.6, 0.8]).is_none());
    // Rotational symmetry: the same ray rotated about the axis gives the rotated output.
    // The ray from (0, 1.5) toward the middle of its pass ellipse, and the same rotated by 90 deg.
    let e = rtf.pass_ellipse(1.5).unwrap();
    let v = [
        e.center_mm[0],
        e.center_mm[1] - 1.5,
        rtf.pass_plane_distance_mm,
    ];
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let a = rtf
        .trace([0.0, 1.5], [v[0] / n, v[1] / n, v[2] / n])
        .unwrap();
    let b = rtf
        .trace([1.5, 0.0], [v[1] / n, -v[0] / n, v[2] / n])
        .unwrap();
    assert!(
        (a.0[1] - b.0[0]).abs() < 1e-12 && (a.0[0] + b.0[1]).abs() < 1e-12,
        "{a:?} {b:?}"
    );
}
