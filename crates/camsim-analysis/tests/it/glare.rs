//! Veiling glare index (ISO 18844) on a synthetic target image: a black hole of radius R in a
//! bright annulus out to radius S, convolved with a known glare spread function (GSF)
//! g(r) = G (p - 1) r0^(2p - 2) / (pi (r^2 + r0^2)^p). The hole's centre then receives
//! G [E(R) - E(S)], E(x) = (r0^2 / (x^2 + r0^2))^(p - 1) the unit GSF's energy beyond x: the
//! GSF's energy beyond the hole radius times the fraction of it that lands on the surround.

use camsim_analysis::glare::{find_hole, veiling_glare, GlareOptions};
use camsim_analysis::Plane;
use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;

const G: f64 = 0.03;
const P: f64 = 1.5;
const R0_PX: f64 = 8.0;

fn energy_beyond(x: f64) -> f64 {
    (R0_PX * R0_PX / (x * x + R0_PX * R0_PX)).powf(P - 1.0)
}

/// 2-D FFT in place (rows then columns) of an n x n complex array.
fn fft2(data: &mut [Complex64], n: usize, inverse: bool) {
    let mut planner = FftPlanner::new();
    let f = if inverse {
        planner.plan_fft_inverse(n)
    } else {
        planner.plan_fft_forward(n)
    };
    for row in data.chunks_exact_mut(n) {
        f.process(row);
    }
    let mut col = vec![Complex64::new(0.0, 0.0); n];
    for c in 0..n {
        for r in 0..n {
            col[r] = data[r * n + c];
        }
        f.process(&mut col);
        for r in 0..n {
            data[r * n + c] = col[r];
        }
    }
}

/// The target (hole radius r_hole, annulus to s_px, level 1) convolved with (1 - G) delta + g,
/// linear convolution by a zero-padded FFT; plus a black level of 64 that the caller subtracts.
fn synthetic(side: usize, r_hole: f64, s_px: f64) -> Plane {
    let n = 2 * side;
    let c = side as f64 / 2.0;
    let mut img = vec![Complex64::new(0.0, 0.0); n * n];
    for i in 0..side {
        for j in 0..side {
            let d = ((i as f64 + 0.5 - c).powi(2) + (j as f64 + 0.5 - c).powi(2)).sqrt();
            if d >= r_hole && d < s_px {
                img[i * n + j].re = 1.0;
            }
        }
    }
    let mut k = vec![Complex64::new(0.0, 0.0); n * n];
    let norm = (P - 1.0) * R0_PX.powf(2.0 * P - 2.0) / std::f64::consts::PI;
    for di in -(side as i64)..side as i64 {
        for dj in -(side as i64)..side as i64 {
            let r2 = (di * di + dj * dj) as f64;
            let v = if r2 == 0.0 {
                1.0 - G + G * (1.0 - energy_beyond(1.0 / std::f64::consts::PI.sqrt()))
            } else {
                G * norm / (r2 + R0_PX * R0_PX).powf(P)
            };
            let (r, cc) = (
                di.rem_euclid(n as i64) as usize,
                dj.rem_euclid(n as i64) as usize,
            );
            k[r * n + cc].re = v;
        }
    }
    fft2(&mut img, n, false);
    fft2(&mut k, n, false);
    img.iter_mut().zip(&k).for_each(|(a, b)| *a *= *b);
    fft2(&mut img, n, true);
    let scale = 1.0 / (n * n) as f64;
    let data = (0..side * side)
        .map(|i| (img[(i / side) * n + i % side].re * scale + 64.0) as f32)
        .collect();
    Plane::new(side, side, data).unwrap()
}

#[test]
fn glare_index_of_a_convolved_target_is_the_closed_form() {
    let (side, r_hole, s_px) = (256usize, 40.0, 120.0);
    let mut p = synthetic(side, r_hole, s_px);
    // Black-level subtraction, as the caller does for raw data.
    p.data.iter_mut().for_each(|v| *v -= 64.0);
    let ((cx, cy), d) = {
        let (c, d) = find_hole(&p, None).unwrap();
        ((c[0], c[1]), d)
    };
    assert!(
        (cx - 128.0).abs() < 0.05 && (cy - 128.0).abs() < 0.05,
        "centre {cx}, {cy}"
    );
    assert!((d / (2.0 * r_hole) - 1.0).abs() < 0.02, "diameter {d}");
    let m = veiling_glare(&p, &GlareOptions::default()).unwrap();
    let want = G * (energy_beyond(r_hole) - energy_beyond(s_px));
    eprintln!(
        "glare index {:.5} (hole {:.5}, surround {:.5}), closed form {want:.5}",
        m.glare_index, m.hole_signal, m.surround_signal
    );
    assert!(
        (m.glare_index / want - 1.0).abs() < 0.05,
        "{} vs {want}",
        m.glare_index
    );
    // No glare: the hole is dark.
    let mut flat = p.clone();
    for i in 0..side {
        for j in 0..side {
            let dd = ((i as f64 + 0.5 - 128.0).powi(2) + (j as f64 + 0.5 - 128.0).powi(2)).sqrt();
            flat.data[i * side + j] = if dd >= r_hole && dd < s_px { 1.0 } else { 0.0 };
        }
    }
    let m0 = veiling_glare(&flat, &GlareOptions::default()).unwrap();
    assert_eq!(m0.glare_index, 0.0);
    assert!((m0.hole_diameter_px / 80.0 - 1.0).abs() < 0.02);
}

#[test]
fn bad_inputs_are_errors_naming_what() {
    let bright = Plane::new(32, 32, vec![1.0; 1024]).unwrap();
    let e = veiling_glare(&bright, &GlareOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("no dark hole"), "{e}");
    let dark = Plane::new(32, 32, vec![0.0; 1024]).unwrap();
    let e = veiling_glare(&dark, &GlareOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("surround"), "{e}");
    let mut edge = vec![1.0f32; 1024];
    for r in 0..32 {
        for c in 10..20 {
            edge[r * 32 + c] = 0.0;
        }
    }
    let edge = Plane::new(32, 32, edge).unwrap();
    let e = veiling_glare(&edge, &GlareOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("image edge"), "{e}");
    let o = GlareOptions {
        roi_fraction: 1.5,
        ..GlareOptions::default()
    };
    let e = veiling_glare(&bright, &o).unwrap_err().to_string();
    assert!(e.contains("roi_fraction"), "{e}");
}
