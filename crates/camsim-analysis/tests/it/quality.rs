//! PSNR, SSIM, CIE94 and CIE 1976 u*v* against closed forms (issue 42 item 7).

use camsim_analysis::quality::{psnr_db, quality, ssim};
use camsim_analysis::{cie94, delta_e_uv, xyz_to_luv, Lab, Plane};

fn plane(rows: usize, cols: usize, f: impl Fn(usize, usize) -> f64) -> Plane {
    let data = (0..rows * cols)
        .map(|i| f(i / cols, i % cols) as f32)
        .collect();
    Plane::new(rows, cols, data).unwrap()
}

/// PSNR of an image against itself plus a constant d: MSE = d^2.
#[test]
fn psnr_of_a_constant_offset_is_its_closed_form() {
    let a = plane(20, 30, |r, c| ((r * 7 + c * 3) % 200) as f64);
    let b = plane(20, 30, |r, c| ((r * 7 + c * 3) % 200) as f64 + 4.0);
    let got = psnr_db(&a, &b, 255.0).unwrap();
    let want = 10.0 * (255.0f64 * 255.0 / 16.0).log10();
    assert!((got - want).abs() < 1e-9, "{got} vs {want}");
    assert!(psnr_db(&a, &a, 255.0).unwrap().is_infinite());
    let small = plane(20, 29, |_, _| 0.0);
    assert!(psnr_db(&a, &small, 255.0).is_err());
}

/// SSIM's three closed forms: 1 for identical images; for two flat images the luminance term
/// alone, (2 mx my + C1) / (mx^2 + my^2 + C1); for a +-a checkerboard around one mean against
/// the same board at k times the contrast (the Gaussian window's alternating sum is ~1e-5, so
/// every window sees the same mean and variance a^2) the contrast-structure term alone,
/// (2 k a^2 + C2) / ((1 + k^2) a^2 + C2); and -1-ish for the board against its negative.
#[test]
fn ssim_follows_its_closed_forms() {
    let (rows, cols, l) = (24, 24, 255.0);
    let (c1, c2) = ((0.01f64 * l).powi(2), (0.03f64 * l).powi(2));
    let board =
        |a: f64| move |r: usize, c: usize| 120.0 + if (r + c).is_multiple_of(2) { a } else { -a };
    let x = plane(rows, cols, board(20.0));
    assert!((ssim(&x, &x, l).unwrap() - 1.0).abs() < 1e-12);

    let (mx, my) = (100.0, 60.0);
    let got = ssim(
        &plane(rows, cols, |_, _| mx),
        &plane(rows, cols, |_, _| my),
        l,
    )
    .unwrap();
    let want = (2.0 * mx * my + c1) / (mx * mx + my * my + c1);
    assert!((got - want).abs() < 1e-9, "flat: {got} vs {want}");

    let (a, k) = (20.0, 0.4);
    let got = ssim(&x, &plane(rows, cols, board(k * a)), l).unwrap();
    let want = (2.0 * k * a * a + c2) / ((1.0 + k * k) * a * a + c2);
    assert!((got - want).abs() < 1e-4, "contrast: {got} vs {want}");
    let got = ssim(&x, &plane(rows, cols, board(-a)), l).unwrap();
    let want = (-2.0 * a * a + c2) / (2.0 * a * a + c2);
    assert!((got - want).abs() < 1e-4, "negative: {got} vs {want}");
    // Channels: PSNR from the pooled MSE, SSIM the channels' mean.
    let q = quality(
        &[x.clone(), x.clone()],
        &[x.clone(), plane(rows, cols, board(-a))],
        l,
    )
    .unwrap();
    assert!((q.ssim.unwrap() - (1.0 + want) / 2.0).abs() < 1e-4);
    let mse = (2.0f64 * a).powi(2) / 2.0;
    assert!((q.psnr_db - 10.0 * (l * l / mse).log10()).abs() < 1e-9);
    assert!(ssim(&plane(8, 30, |_, _| 0.0), &plane(8, 30, |_, _| 0.0), l).is_err());
    // A frame narrower than the window still has its PSNR; its SSIM is absent.
    let thin = quality(&[plane(8, 30, |_, _| 1.0)], &[plane(8, 30, |_, _| 2.0)], l).unwrap();
    assert!(thin.ssim.is_none() && (thin.psnr_db - 10.0 * (l * l).log10()).abs() < 1e-9);
}

/// CIE94 (graphic arts): a pure lightness difference is itself; a pure chroma difference at one
/// hue is divided by 1 + 0.045 C1; a pure hue difference at equal chroma, the chord
/// 2 C sin(dh / 2), by 1 + 0.015 C1.
#[test]
fn cie94_follows_its_weighting_functions() {
    let r = Lab::new(50.0, 30.0, 40.0); // C = 50
    assert!((cie94(r, Lab::new(47.0, 30.0, 40.0)) - 3.0).abs() < 1e-12);
    let s = Lab::new(50.0, 30.0 * 0.9, 40.0 * 0.9); // C = 45, same hue
    assert!((cie94(r, s) - 5.0 / (1.0 + 0.045 * 50.0)).abs() < 1e-12);
    let h = 0.1f64;
    let (c0, s0) = (30.0f64 / 50.0, 40.0f64 / 50.0);
    let rot = Lab::new(
        50.0,
        50.0 * (c0 * h.cos() - s0 * h.sin()),
        50.0 * (s0 * h.cos() + c0 * h.sin()),
    );
    let want = 2.0 * 50.0 * (h / 2.0).sin() / (1.0 + 0.015 * 50.0);
    assert!((cie94(r, rot) - want).abs() < 1e-9);
}

/// CIELUV: the white is (100, 0, 0); D65's u'v' (0.1978, 0.4683 from x, y = 0.3127, 0.3290;
/// CIE 015:2018 table 11.3 gives x, y); a grey at the white's chromaticity has u* = v* = 0, so
/// dEuv between two greys is their L* difference; u* = 13 L* (u' - u'n) for a colour.
#[test]
fn cieluv_follows_its_definition() {
    let white = [95.047, 100.0, 108.883];
    let w = xyz_to_luv(white, white);
    assert!((w[0] - 100.0).abs() < 1e-9 && w[1].abs() < 1e-9 && w[2].abs() < 1e-9);
    let d = white[0] + 15.0 * white[1] + 3.0 * white[2];
    assert!((4.0 * white[0] / d - 0.1978).abs() < 1e-4);
    assert!((9.0 * white[1] / d - 0.4683).abs() < 1e-4);
    let grey = |y: f64| white.map(|v| v * y / 100.0);
    let l1 = xyz_to_luv(grey(50.0), white)[0];
    let l2 = xyz_to_luv(grey(20.0), white)[0];
    assert!((delta_e_uv(grey(50.0), grey(20.0), white) - (l1 - l2)).abs() < 1e-9);
    let c = [30.0, 20.0, 10.0];
    let luv = xyz_to_luv(c, white);
    let dc = c[0] + 15.0 * c[1] + 3.0 * c[2];
    let want_u = 13.0 * luv[0] * (4.0 * c[0] / dc - 4.0 * white[0] / d);
    assert!((luv[1] - want_u).abs() < 1e-9);
    assert_eq!(xyz_to_luv([0.0; 3], white), [0.0, 0.0, 0.0]);
}
