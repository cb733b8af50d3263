//! Relative illumination of the Pixel 4a rear lens from its ray-transfer function (ISET/
//! isetcornellbox `pixel4a-rearcamera-ellipse-raytransfer.json`, Goossens et al. 2022) against the
//! lens maker's Zemax design (`zemax-relative-illumination.txt`, 555 nm).

use camsim_lens::rtf::{read_zemax_relative_illumination, Rtf};
use std::path::Path;

const LENS_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/isetcornellbox/lens");

#[test]
fn rtf_relative_illumination_matches_zemax() {
    let rtf = Rtf::from_file(&Path::new(LENS_DIR).join("pixel4a-rearcamera-ellipse-raytransfer.json")).unwrap();
    let zemax = read_zemax_relative_illumination(&Path::new(LENS_DIR).join("zemax-relative-illumination.txt")).unwrap();
    assert_eq!(zemax.len(), 21);
    let heights: Vec<f64> = zemax.iter().map(|r| r.height_mm).collect();
    let ri = rtf.relative_illumination(&heights, 400);
    println!("| image height (mm) | Zemax RI | RTF RI | difference | relative |");
    let mut worst_abs: f64 = 0.0;
    for (z, r) in zemax.iter().zip(&ri) {
        let r = r.expect("inside the RTF's table");
        let d = r - z.ri;
        worst_abs = worst_abs.max(d.abs());
        println!("| {:.4} | {:.4} | {:.4} | {:+.4} | {:+.2} % |", z.height_mm, z.ri, r, d, 100.0 * d / z.ri);
    }
    println!("largest |RTF - Zemax| = {worst_abs:.4}");
    assert!(worst_abs <= 0.02, "{worst_abs}");
}

#[test]
fn rtf_on_axis_point_leaves_collimated_and_the_focal_length_is_4_38_mm() {
    // A film point on the axis leaves as a parallel beam (the input plane is the focal plane).
    let rtf = Rtf::from_file(&Path::new(LENS_DIR).join("pixel4a-rearcamera-ellipse-raytransfer.json")).unwrap();
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
    let v = [e.center_mm[0], e.center_mm[1] - 1.5, rtf.pass_plane_distance_mm];
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let a = rtf.trace([0.0, 1.5], [v[0] / n, v[1] / n, v[2] / n]).unwrap();
    let b = rtf.trace([1.5, 0.0], [v[1] / n, -v[0] / n, v[2] / n]).unwrap();
    assert!((a.0[1] - b.0[0]).abs() < 1e-12 && (a.0[0] + b.0[1]).abs() < 1e-12, "{a:?} {b:?}");
}
