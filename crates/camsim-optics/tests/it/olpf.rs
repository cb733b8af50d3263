//! The birefringent optical low-pass filter (issue 42 item 4) against its closed forms: a
//! 2-spot filter of displacement d has MTF |cos(pi f d)| along its axis and 1 across it; the
//! 4-spot filter the product over x and y; spots a whole number of samples apart give the mean
//! of the two shifted images exactly; the filter moves no energy.

use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_optics::olpf::{apply, OlpfConfig};
use std::f64::consts::PI;

const SPACING_M: f64 = 1e-6;

fn image(rows: usize, cols: usize, f: impl Fn(usize, usize) -> f64) -> SpectralImage {
    let grid = WavelengthGrid::new(500.0, 510.0, 10.0).unwrap();
    let mut data = Vec::with_capacity(rows * cols * 2);
    for b in 0..2 {
        for r in 0..rows {
            for c in 0..cols {
                data.push((f(r, c) * (1.0 + b as f64)) as f32);
            }
        }
    }
    SpectralImage::from_data(rows, cols, grid, SPACING_M, Quantity::Irradiance, data).unwrap()
}

/// The amplitude of the period-`p` sinusoid along x in row `r` of band 0, over whole periods
/// in the middle of the row (away from the edge padding).
fn amplitude(img: &SpectralImage, r: usize, p: usize, along_y: bool) -> f64 {
    let n = if along_y { img.rows } else { img.cols };
    let periods = (n / 2) / p;
    let start = (n - periods * p) / 2;
    let (mut s, mut c) = (0.0, 0.0);
    for k in start..start + periods * p {
        let v = if along_y {
            img.data[k * img.cols + r]
        } else {
            img.data[r * img.cols + k]
        } as f64;
        let ph = 2.0 * PI * k as f64 / p as f64;
        s += v * ph.sin();
        c += v * ph.cos();
    }
    2.0 * s.hypot(c) / (periods * p) as f64
}

fn olpf(spots: u32, d_um: f64) -> OlpfConfig {
    OlpfConfig {
        spots,
        displacement_um: d_um,
        displacement_y_um: None,
    }
}

#[test]
fn a_two_spot_filter_has_the_cosine_mtf_along_its_axis_and_none_across() {
    let d_um = 1.7; // samples (1 um spacing), not a whole number
    let cfg = olpf(2, d_um);
    for p in [40usize, 12, 6, 4] {
        let f = 1.0 / p as f64; // cycles per um
        let mut img = image(8, 240, |_, c| {
            1.0 + 0.5 * (2.0 * PI * c as f64 / p as f64).sin()
        });
        apply(&mut img, &cfg).unwrap();
        let got = amplitude(&img, 3, p, false) / 0.5;
        let want = (PI * f * d_um).cos().abs();
        assert!(
            (got - want).abs() < 2e-3,
            "period {p} um: MTF {got:.4}, cos(pi f d) = {want:.4}"
        );
        assert!((cfg.mtf(f * 1e3, 0.0) - want).abs() < 1e-12);
        // Across: a sinusoid along y is untouched.
        let mut img = image(240, 8, |r, _| {
            1.0 + 0.5 * (2.0 * PI * r as f64 / p as f64).sin()
        });
        let before = img.data.clone();
        apply(&mut img, &cfg).unwrap();
        let worst = img
            .data
            .iter()
            .zip(&before)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(
            worst < 1e-5,
            "a 2-spot filter changed the y direction by {worst}"
        );
    }
}

#[test]
fn a_four_spot_filter_is_the_product_over_x_and_y() {
    let cfg = OlpfConfig {
        spots: 4,
        displacement_um: 1.3,
        displacement_y_um: Some(2.2),
    };
    let p = 8usize;
    let f = 1.0 / p as f64;
    let mut img = image(96, 96, |r, c| {
        1.0 + 0.25 * (2.0 * PI * c as f64 / p as f64).sin()
            + 0.25 * (2.0 * PI * r as f64 / p as f64).sin()
    });
    apply(&mut img, &cfg).unwrap();
    let x = amplitude(&img, 48, p, false) / 0.25;
    let y = amplitude(&img, 48, p, true) / 0.25;
    assert!((x - (PI * f * 1.3).cos().abs()).abs() < 3e-3, "x MTF {x}");
    assert!((y - (PI * f * 2.2).cos().abs()).abs() < 3e-3, "y MTF {y}");
}

/// Spots 2 samples apart land exactly on the neighbours: out(c) = (in(c - 1) + in(c + 1)) / 2,
/// and the total of an image whose edges are flat is kept.
#[test]
fn whole_sample_spots_average_the_shifted_images_and_keep_the_energy() {
    let cols = 64;
    let g = |c: usize| (-((c as f64 - 32.0) / 4.0).powi(2)).exp() + 0.1;
    let mut img = image(2, cols, |_, c| g(c));
    apply(&mut img, &olpf(2, 2.0)).unwrap();
    for c in 1..cols - 1 {
        let want = (g(c - 1) + g(c + 1)) / 2.0;
        let got = img.data[cols + c] as f64;
        assert!((got - want).abs() < 1e-5, "column {c}: {got} vs {want}");
    }
    let sum_in: f64 = (0..cols).map(g).sum();
    let sum_out: f64 = img.data[..cols].iter().map(|v| *v as f64).sum();
    assert!(
        (sum_out / sum_in - 1.0).abs() < 1e-5,
        "{sum_out} vs {sum_in}"
    );
    // The second band (twice the first) is filtered the same way.
    assert!((img.data[2 * cols + 10] / img.data[10] - 2.0).abs() < 1e-5);
}

#[test]
fn bad_olpf_keys_are_refused_naming_them() {
    let mut img = image(4, 4, |_, _| 1.0);
    for (cfg, key) in [
        (olpf(3, 1.0), "olpf.spots"),
        (olpf(4, -1.0), "olpf.displacement_um"),
        (
            OlpfConfig {
                spots: 2,
                displacement_um: 1.0,
                displacement_y_um: Some(1.0),
            },
            "olpf.displacement_y_um",
        ),
    ] {
        let e = apply(&mut img, &cfg).unwrap_err().to_string();
        assert!(e.contains(key), "{e}");
    }
}
