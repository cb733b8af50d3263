//! Noise-free mean signal against an independent quadrature of E(lambda) QE(lambda) lambda/(h c),
//! and the area integration of the irradiance onto the pixel grid against conservation laws.

use crate::common;
use camsim_core::units::{planck_radiance_w_per_sr_m2_nm, PLANCK_J_S, SPEED_OF_LIGHT_M_PER_S};
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_sensor::{Capture, Sensor};
use common::{channel_pixels, config, quiet, read_csv, uniform_image};

/// Independent QE model: linear interpolation of the published table (CSV read here, filter x IR),
/// optionally times M (rows = input channel), 0 outside 390-710 nm.
fn qe_reference(lambda_nm: f64, m: Option<[[f64; 3]; 3]>) -> [f64; 3] {
    thread_local! { static TABLE: Vec<Vec<f64>> = read_csv("imx363_qe.csv"); }
    TABLE.with(|t| {
        let mut out = [0.0; 3];
        if lambda_nm < t[0][0] || lambda_nm > t[t.len() - 1][0] {
            return out;
        }
        let i = t.iter().position(|r| r[0] >= lambda_nm).unwrap().max(1);
        let (a, b) = (&t[i - 1], &t[i]);
        let u = (lambda_nm - a[0]) / (b[0] - a[0]);
        let raw: Vec<f64> = (0..3)
            .map(|c| (a[1 + c] * a[4]) * (1.0 - u) + (b[1 + c] * b[4]) * u)
            .collect();
        for c in 0..3 {
            out[c] = match m {
                None => raw[c],
                Some(m) => (0..3).map(|i| raw[i] * m[i][c]).sum(),
            };
        }
        out
    })
}

/// Composite Simpson integral of f over [a, b] with n (even) intervals.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for k in 1..n {
        s += f(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

struct Illuminant {
    name: &'static str,
    /// Relative spectral irradiance shape at lambda (nm).
    shape: fn(f64) -> f64,
}

fn illuminants() -> Vec<Illuminant> {
    vec![
        Illuminant {
            name: "blackbody 2856 K",
            shape: |l| planck_radiance_w_per_sr_m2_nm(l, 2856.0),
        },
        Illuminant {
            name: "blackbody 6500 K",
            shape: |l| planck_radiance_w_per_sr_m2_nm(l, 6500.0),
        },
        Illuminant {
            name: "flat",
            shape: |_| 1.0,
        },
        // A narrow band: Gaussian at 532 nm, sigma 4 nm.
        Illuminant {
            name: "narrow band 532 nm",
            shape: |l| (-0.5 * ((l - 532.0) / 4.0).powi(2)).exp(),
        },
    ]
}

/// Electrons per pixel for each channel: integral over [lo, hi] of E QE lambda/(h c) x area x t.
fn reference_electrons(
    e_w_per_m2_nm: &dyn Fn(f64) -> f64,
    m: Option<[[f64; 3]; 3]>,
    area_m2: f64,
    t_s: f64,
    lo: f64,
    hi: f64,
) -> [f64; 3] {
    let mut out = [0.0; 3];
    for (c, o) in out.iter_mut().enumerate() {
        *o = simpson(
            |l| {
                e_w_per_m2_nm(l) * qe_reference(l, m)[c] * (l * 1e-9)
                    / (PLANCK_J_S * SPEED_OF_LIGHT_M_PER_S)
            },
            lo,
            hi,
            6000,
        ) * area_m2
            * t_s;
    }
    out
}

/// Uniform fields of several illuminants through imx363 and pixel4a, noise-free: the sensor's mean
/// electrons (and every pixel's unrounded DN / K) equal the independent integral within 0.5 %.
/// The image is sampled every 1 nm over 400-700 nm; each band stands for 1 nm of spectrum, so the
/// reference integrates over [399.5, 700.5] (the IR-cut filter makes the ends negligible anyway).
#[test]
fn mean_electrons_equal_the_analytic_integral() {
    let grid = WavelengthGrid::new(400.0, 700.0, 1.0).unwrap();
    for preset in ["imx363", "pixel4a"] {
        let sensor = config(preset, |c| {
            c.rows = 4;
            c.cols = 4;
            c.noise = quiet(true);
        });
        let m = sensor.config().qe_correction;
        let area = sensor.photodetector_area_m2();
        for ill in illuminants() {
            // Scale to 0.01 W/(m^2 nm) at the peak of the shape over the grid.
            let peak = grid
                .wavelengths_nm()
                .iter()
                .map(|l| (ill.shape)(*l))
                .fold(0.0, f64::max);
            let e = move |l: f64| 0.01 * (ill.shape)(l) / peak;
            let spectrum: Vec<f64> = grid.wavelengths_nm().iter().map(|l| e(*l)).collect();
            // Exposure that puts the brightest channel at ~3000 e-.
            let per_s = reference_electrons(&e, m, area, 1.0, 399.5, 700.5);
            let t = 3000.0 / per_s.iter().cloned().fold(0.0, f64::max);
            let reference = reference_electrons(&e, m, area, t, 399.5, 700.5);
            let img = uniform_image(6, 6, grid, sensor.pixel_pitch_m(), &spectrum);
            let frame = sensor.compute(&img, &Capture::seconds(t)).unwrap();
            let analytic = sensor.mean_electrons_uniform(&spectrum, &grid, t).unwrap();
            let analog = &frame.analog_dn.as_ref().unwrap()[0];
            for c in 0..3 {
                let err = frame.mean_electrons[c] / reference[c] - 1.0;
                let err_helper = analytic[c] / reference[c] - 1.0;
                eprintln!(
                    "{preset} {} channel {c}: {:.1} e- vs reference {:.1} e- ({:+.4} %)",
                    ill.name,
                    frame.mean_electrons[c],
                    reference[c],
                    100.0 * err
                );
                assert!(
                    err.abs() < 0.005,
                    "{preset} {} channel {c}: relative error {err}",
                    ill.name
                );
                assert!(
                    err_helper.abs() < 0.005,
                    "{preset} {} channel {c}: helper error {err_helper}",
                    ill.name
                );
                for i in channel_pixels(&frame.raw[0], c) {
                    let e_pix = analog[i] as f64 / sensor.k_dn_per_e();
                    assert!(
                        (e_pix / reference[c] - 1.0).abs() < 0.005,
                        "pixel {i}: {e_pix} vs {}",
                        reference[c]
                    );
                }
            }
        }
    }
}

/// On ISETCam's default 31-band grid (400-700 nm every 10 nm) the band sum still equals the
/// integral within 0.5 % for smooth (blackbody) illuminants.
#[test]
fn default_grid_is_accurate_for_smooth_illuminants() {
    let grid = WavelengthGrid::default();
    let sensor = config("imx363", |c| {
        c.rows = 2;
        c.cols = 2;
        c.noise = quiet(true);
    });
    for temp in [2856.0, 4000.0, 6500.0] {
        let e = move |l: f64| {
            1e-3 * planck_radiance_w_per_sr_m2_nm(l, temp)
                / planck_radiance_w_per_sr_m2_nm(550.0, temp)
        };
        let spectrum: Vec<f64> = grid.wavelengths_nm().iter().map(|l| e(*l)).collect();
        let got = sensor
            .mean_electrons_uniform(&spectrum, &grid, 1.0)
            .unwrap();
        let want = reference_electrons(&e, None, sensor.photodetector_area_m2(), 1.0, 395.0, 705.0);
        for c in 0..3 {
            let err = got[c] / want[c] - 1.0;
            eprintln!("31 bands, {temp} K, channel {c}: {:+.4} %", 100.0 * err);
            assert!(err.abs() < 0.005, "{temp} K channel {c}: {err}");
        }
    }
}

/// The ideal sensor (QE 1, no noise) counts every photon reaching the photodetector:
/// electrons = sum E lambda/(h c) d lambda x pitch^2 x fill factor x t, for each CFA channel.
#[test]
fn ideal_sensor_counts_photons() {
    let grid = WavelengthGrid::default();
    let sensor = config("ideal", |c| {
        c.fill_factor = 0.5;
        c.noise.quantization = false;
    });
    let spectrum: Vec<f64> = grid
        .wavelengths_nm()
        .iter()
        .map(|l| 1e-3 * (l / 550.0))
        .collect();
    let t = 0.01;
    let photons: f64 = grid
        .wavelengths_nm()
        .iter()
        .zip(&spectrum)
        .map(|(l, e)| e * 10.0 * l * 1e-9 / (PLANCK_J_S * SPEED_OF_LIGHT_M_PER_S))
        .sum::<f64>()
        * (1.4e-6f64).powi(2)
        * 0.5
        * t;
    let img = uniform_image(64, 64, grid, 1.4e-6, &spectrum);
    let frame = sensor.compute(&img, &Capture::seconds(t)).unwrap();
    for c in 0..3 {
        assert!(
            (frame.mean_electrons[c] / photons - 1.0).abs() < 1e-5,
            "{} vs {photons}",
            frame.mean_electrons[c]
        );
    }
    let analog = &frame.analog_dn.unwrap()[0];
    let k = sensor.k_dn_per_e();
    assert!(analog
        .iter()
        .all(|v| ((*v as f64) / k / photons - 1.0).abs() < 1e-5));
}

/// A 1-band ideal sensor (QE 1, fill factor 1) whose photon rate per pixel is simply E x area x
/// lambda/(h c) x step: used to check the area integration against closed forms.
fn mono_ideal(rows: usize, cols: usize, fill_factor: f64) -> (Sensor, WavelengthGrid, f64) {
    let grid = WavelengthGrid::new(550.0, 550.0, 1.0).unwrap();
    let s = config("ideal", |c| {
        c.rows = rows;
        c.cols = cols;
        c.fill_factor = fill_factor;
        c.noise = quiet(true);
    });
    // electrons per (W/(m^2 nm)) per second per m^2 of photodetector.
    let k = 550e-9 / (PLANCK_J_S * SPEED_OF_LIGHT_M_PER_S);
    (s, grid, k)
}

fn pseudo_random_image(
    rows: usize,
    cols: usize,
    grid: WavelengthGrid,
    spacing_m: f64,
) -> SpectralImage {
    let mut img = SpectralImage::zeros(rows, cols, grid, spacing_m, Quantity::Irradiance).unwrap();
    for (i, v) in img.data.iter_mut().enumerate() {
        // A fixed, irregular pattern (Weyl sequence), 0.5..1.5 W/(m^2 nm).
        *v = 0.5 + ((i as f64 * 0.618_033_988_75).fract()) as f32;
    }
    img
}

/// Energy conservation: a sensor larger than the image collects every photon of it, whether the
/// irradiance is sampled finer or coarser than the pixels (fill factor 1).
#[test]
fn area_integration_conserves_photons() {
    for (spacing_ratio, in_rows, in_cols) in
        [(0.37, 50, 61), (1.0, 20, 21), (2.5, 7, 9), (0.5, 40, 40)]
    {
        let (sensor, grid, k) = mono_ideal(48, 48, 1.0);
        let p = sensor.pixel_pitch_m();
        let img = pseudo_random_image(in_rows, in_cols, grid, p * spacing_ratio);
        let rate = sensor.electron_rate_image(&img).unwrap();
        let total: f64 = rate.iter().map(|v| *v as f64).sum();
        let cell_area = (p * spacing_ratio).powi(2);
        let want: f64 = img.data.iter().map(|v| *v as f64).sum::<f64>() * cell_area * k;
        assert!(
            (total / want - 1.0).abs() < 1e-5,
            "spacing {spacing_ratio} x pitch: {total} vs {want}"
        );
    }
}

/// Finer sampling, fill factor 1/4: the photodetector (centred square of half the pitch) sees the
/// mean of the central 2 x 2 of the 4 x 4 samples in each pixel (irradiance spacing = pitch / 4).
#[test]
fn fill_factor_photodetector_sees_the_centre_of_the_pixel() {
    let (sensor, grid, k) = mono_ideal(8, 10, 0.25);
    let p = sensor.pixel_pitch_m();
    let img = pseudo_random_image(32, 40, grid, p / 4.0);
    let rate = sensor.electron_rate_image(&img).unwrap();
    let area = sensor.photodetector_area_m2();
    for r in 0..8 {
        for c in 0..10 {
            let mut m = 0.0;
            for i in 1..3 {
                for j in 1..3 {
                    m += img.at(4 * r + i, 4 * c + j, 0) as f64 / 4.0;
                }
            }
            let want = m * area * k;
            let got = rate[r * 10 + c] as f64;
            assert!(
                (got / want - 1.0).abs() < 1e-5,
                "pixel ({r}, {c}): {got} vs {want}"
            );
        }
    }
}

/// Coarser sampling with the image centred on the axis: an irradiance image of 5 x 5 samples of
/// 2 pitches covers the central 10 x 10 pixels of a 12 x 12 sensor, each sample exactly 2 x 2
/// pixels; the border pixels see nothing.
#[test]
fn coarse_image_is_centred_and_zero_outside() {
    let (sensor, grid, k) = mono_ideal(12, 12, 1.0);
    let p = sensor.pixel_pitch_m();
    let img = pseudo_random_image(5, 5, grid, 2.0 * p);
    let rate = sensor.electron_rate_image(&img).unwrap();
    let area = sensor.photodetector_area_m2();
    for r in 0..12 {
        for c in 0..12 {
            let got = rate[r * 12 + c] as f64;
            if r == 0 || c == 0 || r == 11 || c == 11 {
                assert_eq!(got, 0.0, "border pixel ({r}, {c})");
            } else {
                let want = img.at((r - 1) / 2, (c - 1) / 2, 0) as f64 * area * k;
                assert!(
                    (got / want - 1.0).abs() < 1e-5,
                    "pixel ({r}, {c}): {got} vs {want}"
                );
            }
        }
    }
}

/// Same pitch, image larger than the sensor by an odd number of samples: the sensor window is
/// centred, so each pixel straddles two samples and sees their mean along that axis.
#[test]
fn half_sample_offset_averages_neighbours() {
    let (sensor, grid, k) = mono_ideal(4, 4, 1.0);
    let p = sensor.pixel_pitch_m();
    let img = pseudo_random_image(4, 5, grid, p);
    let rate = sensor.electron_rate_image(&img).unwrap();
    let area = sensor.photodetector_area_m2();
    for r in 0..4 {
        for c in 0..4 {
            let want = 0.5 * (img.at(r, c, 0) + img.at(r, c + 1, 0)) as f64 * area * k;
            let got = rate[r * 4 + c] as f64;
            assert!(
                (got / want - 1.0).abs() < 1e-5,
                "pixel ({r}, {c}): {got} vs {want}"
            );
        }
    }
}
