//! The optics stage on images: irradiance formula, shading, energy conservation, the edge MTF
//! (frequency domain), depth-layered defocus.

use camsim_core::image::ImageGeometry;
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_optics::config::{BlurMethod, Padding, ShadingConfig, ShadingName};
use camsim_optics::{diffraction_mtf, Optics, OpticsConfig};
use std::f64::consts::PI;

fn config(n: f64, f_mm: f64) -> OpticsConfig {
    let mut c = OpticsConfig::preset("diffraction-limited").unwrap();
    c.f_number = n;
    c.focal_length_mm = f_mm;
    c.shading = ShadingConfig::Named(ShadingName::None);
    c
}

fn image(
    rows: usize,
    cols: usize,
    grid: WavelengthGrid,
    spacing_m: f64,
    distance_m: f64,
    f: impl Fn(usize, usize, usize) -> f32,
) -> SpectralImage {
    let mut data = vec![0.0f32; rows * cols * grid.len()];
    for b in 0..grid.len() {
        for r in 0..rows {
            for c in 0..cols {
                data[(b * rows + r) * cols + c] = f(b, r, c);
            }
        }
    }
    let mut img =
        SpectralImage::from_data(rows, cols, grid, spacing_m, Quantity::Radiance, data).unwrap();
    img.geometry = ImageGeometry {
        fov_deg: 0.0,
        distance_m,
        focal_length_m: 0.0,
        f_number: 0.0,
    };
    img
}

/// Uniform field: E = pi T L / (1 + 4 N^2 (1 + m)^2) (ISETCam oiCalculateIrradiance), m = v/d from
/// the thin lens; the blur leaves a uniform field unchanged away from the borders; the sensor-plane
/// spacing is the scene spacing times v/d.
#[test]
fn uniform_field_irradiance_follows_the_camera_equation() {
    let grid = WavelengthGrid::new(450.0, 650.0, 100.0).unwrap();
    for &(n, f_mm, d, t) in &[
        (2.8, 50.0, 1.0, 0.9),
        (1.73, 4.38, 0.5, 1.0),
        (4.0, 10.0, 0.05, 0.8),
    ] {
        for (method, far_tail) in [
            (BlurMethod::Otf, true),
            (BlurMethod::Kernel, true),
            (BlurMethod::Kernel, false),
        ] {
            let mut c = config(n, f_mm);
            c.transmittance = camsim_optics::config::Transmittance::Scalar(t);
            c.psf.method = method;
            c.psf.far_tail = far_tail;
            let o = Optics::from_config(&c).unwrap();
            let f: f64 = f_mm * 1e-3;
            let v = 1.0 / (1.0 / f - 1.0 / d);
            let m = v / d;
            // Scene spacing such that the sensor spacing is 4 um; 128 x 128 samples. The centre misses
            // the light its PSF sends beyond the field: at most the Airy energy outside the inscribed
            // circle r = 64 samples, 2 lambda N_w / (pi^2 r) (Born & Wolf sec. 8.5.2 asymptote; N_w the
            // working f-number N (1 + m)), up to 0.22 % here; at least the energy outside the
            // circumscribed circle; so with kernels and their far tail. With trimmed kernels
            // (`far_tail = false`: renormalized, radius < 64 samples here) the centre gets all of its
            // light back: exact to f32 round-off.
            let scene_dx = 4e-6 / m;
            let img = image(128, 128, grid, scene_dx, d, |b, _, _| 0.01 * (b + 1) as f32);
            let out = o.compute(&img).unwrap();
            assert!((out.sample_spacing_m / 4e-6 - 1.0).abs() < 1e-9);
            assert_eq!(out.geometry.f_number, n);
            let want_k = PI * t / (1.0 + 4.0 * n * n * (1.0 + m) * (1.0 + m));
            for b in 0..3 {
                let got = out.at(out.rows / 2, out.cols / 2, b) as f64;
                let want = want_k * 0.01 * (b + 1) as f64;
                let lam_nw = grid.wavelength_nm(b) * 1e-9 * n * (1.0 + m);
                let e_out = |r_m: f64| 2.0 * lam_nw / (PI * PI * r_m);
                let (lo, hi) = (e_out(64.0 * 4e-6 * 2f64.sqrt()), e_out(64.0 * 4e-6));
                // 2e-4: the asymptote's error at r ~ 100 lambda N (the next term is O((lambda N / r)^2))
                // and f32 irradiance.
                let missing = 1.0 - got / want;
                if !far_tail {
                    assert!(
                        missing.abs() < 1e-5,
                        "trimmed kernels, N {n}, d {d}, band {b}: {got} vs {want}"
                    );
                } else {
                    assert!(missing > lo - 2e-4 && missing < hi + 2e-4, "{method:?}, N {n}, d {d}, band {b}: {got} vs {want} ({:.4} % missing, Airy tail {:.4}..{:.4} %)", missing * 100.0, lo * 100.0, hi * 100.0);
                }
            }
        }
    }
}

/// cos^4 falloff: a uniform field at infinity with a wide field of view; relative illumination at a
/// pixel off axis is cos^4(atan(r / f)) (the blur is negligible for a smooth field).
#[test]
fn cos4_falloff() {
    let grid = WavelengthGrid::new(550.0, 550.0, 10.0).unwrap();
    let mut c = config(2.0, 4.0);
    c.shading = ShadingConfig::Named(ShadingName::Cos4);
    c.padding = Padding::None;
    let o = Optics::from_config(&c).unwrap();
    let cols = 400;
    let mut img = image(40, cols, grid, 1e-6, 0.0, |_, _, _| 1.0);
    img.geometry.fov_deg = 60.0;
    let out = o.compute(&img).unwrap();
    let dx = out.sample_spacing_m;
    assert!((dx - 2.0 * 4e-3 * (30f64).to_radians().tan() / cols as f64).abs() < 1e-15);
    let centre = out.at(20, cols / 2, 0) as f64;
    for col in [250usize, 300, 350] {
        let x = (col as f64 + 0.5 - cols as f64 / 2.0) * dx;
        let cos2 = 1.0 / (1.0 + (x / 4e-3).powi(2));
        let x0 = 0.5 * dx;
        let cos2_0 = 1.0 / (1.0 + (x0 / 4e-3).powi(2));
        let want = (cos2 * cos2) / (cos2_0 * cos2_0);
        let got = out.at(20, col, 0) as f64 / centre;
        assert!(
            (got - want).abs() < 2e-3,
            "col {col}: {got} vs cos^4 {want}"
        );
    }
}

/// A relative-illumination table (normalized field height) is applied as given.
#[test]
fn relative_illumination_table() {
    let grid = WavelengthGrid::new(550.0, 550.0, 10.0).unwrap();
    let text = "f_number = 2.0\nfocal_length_mm = 4.0\npadding = \"none\"\n\
                shading = { relative_illumination = { field_height_normalized = [0.0, 1.0], ri = [1.0, 0.5] } }\n";
    let o = Optics::from_config(&OpticsConfig::from_toml_str(text, "t").unwrap()).unwrap();
    let (rows, cols) = (60, 80);
    let mut img = image(rows, cols, grid, 1e-6, 0.0, |_, _, _| 1.0);
    // 60 degrees over 80 samples: 58 um samples, so the blur is negligible.
    img.geometry.fov_deg = 60.0;
    let out = o.compute(&img).unwrap();
    let centre = out.at(30, 40, 0) as f64;
    // Pixel (30, 70): field height 30.5 samples of a half-diagonal of 50 samples.
    let ri = |r: f64, c: f64| {
        1.0 - 0.5 * ((c + 0.5 - 40.0).powi(2) + (r + 0.5 - 30.0).powi(2)).sqrt() / 50.0
    };
    let want = ri(30.0, 70.0) / ri(30.0, 40.0);
    let got = out.at(30, 70, 0) as f64 / centre;
    assert!((got - want).abs() < 3e-3, "{got} vs {want}");
}

/// The blur conserves energy: the irradiance integral equals the unblurred one (camera equation x
/// radiance integral), band by band, for a random scene and an aberrated wavefront. With trimmed
/// kernels (`far_tail = false`, "psf" padding, unit-volume kernel) all the light is kept (to f32
/// round-off). With the default (whole-image OTF, untrimmed PSF) and with kernels plus their far
/// tail, the light beyond the "psf" margin leaves the output: at most `psf.tail_energy` (the margin
/// is the kernel half-width, chosen so that no more of the PSF's energy lies outside it), and none
/// is created.
#[test]
fn blur_conserves_energy() {
    let grid = WavelengthGrid::new(400.0, 700.0, 150.0).unwrap();
    let text = "f_number = 1.73\nfocal_length_mm = 4.38\nshading = \"none\"\n[wavefront]\n\
                measurement_pupil_mm = 8.0\nzernike_um = [{ j = 4, c = 1.225 }, { j = 7, c = 0.3 }, { j = 12, c = 0.2 }]\n";
    let o = Optics::from_config(&OpticsConfig::from_toml_str(text, "t").unwrap()).unwrap();
    let (rows, cols) = (90, 70);
    let img = image(rows, cols, grid, 1e-6, 0.0, |b, r, c| {
        (((r * 131 + c * 71 + b * 17) % 97) as f32) / 97.0
    });
    let mut img = img;
    img.geometry.fov_deg = 2.0 * (cols as f64 * 0.7e-6 / 2.0 / 4.38e-3).atan().to_degrees();
    let k = PI / (1.0 + 4.0 * 1.73 * 1.73);
    let mut c = OpticsConfig::from_toml_str(text, "t").unwrap();
    let tail = c.psf.tail_energy;
    let out = o.compute(&img).unwrap();
    assert!(out.rows > rows && out.cols > cols);
    c.psf.method = BlurMethod::Kernel;
    let out_tail = Optics::from_config(&c).unwrap().compute(&img).unwrap();
    c.psf.far_tail = false;
    let out_k = Optics::from_config(&c).unwrap().compute(&img).unwrap();
    for b in 0..3 {
        let sin: f64 = img.band(b).iter().map(|v| *v as f64).sum::<f64>() * k;
        let sout_k: f64 = out_k.band(b).iter().map(|v| *v as f64).sum();
        assert!(
            (sout_k / sin - 1.0).abs() < 1e-4,
            "trimmed kernels, band {b}: {sout_k} vs {sin}"
        );
        for (name, o) in [
            ("whole-image OTF", &out),
            ("kernels with far tail", &out_tail),
        ] {
            let sout: f64 = o.band(b).iter().map(|v| *v as f64).sum();
            let lost = 1.0 - sout / sin;
            assert!(
                lost > -1e-6 && lost < tail,
                "{name}, band {b}: {sout} vs {sin} ({:.4} % lost)",
                lost * 100.0
            );
        }
    }
}

/// Issue 2: the band image of an edge blurs as the analytic diffraction MTF says. Vertical step
/// edge, diffraction-limited lens; the derivative of a blurred row is the line-spread function
/// (the derivative of a sampled step is a discrete delta), its DFT the MTF at k / (W dx). The image
/// spacing is < lambda N / 2, so the discrete kernel's transfer function is the OTF itself; the
/// error comes from the truncated PSF tail (tail_energy = 0.002).
#[test]
fn edge_blurs_as_the_diffraction_mtf() {
    let grid = WavelengthGrid::new(450.0, 650.0, 100.0).unwrap();
    let n = 2.8;
    let mut c = config(n, 4.0);
    c.psf.tail_energy = 0.002;
    let o = Optics::from_config(&c).unwrap();
    let dx = 0.45 * 450e-9 * n;
    // Rows >= the kernel, so the centre row integrates the whole PSF along y (the row is the LSF
    // convolved with the step).
    let (rows, cols) = (701, 1500);
    let mut img = image(rows, cols, grid, dx, 0.0, |_, _, c| {
        if c >= cols / 2 {
            1.0
        } else {
            0.0
        }
    });
    img.geometry.fov_deg = 2.0 * (cols as f64 * dx / 2.0 / 4e-3).atan().to_degrees();
    let out = o.compute(&img).unwrap();
    assert!((out.sample_spacing_m / dx - 1.0).abs() < 1e-9);
    let pad = (out.cols - cols) / 2;
    let edge = pad + cols / 2;
    let w = 1024usize;
    let mut worst: f64 = 0.0;
    for b in 0..3 {
        let wl = grid.wavelength_nm(b);
        let r = out.rows / 2;
        let row: Vec<f64> = (0..out.cols).map(|c| out.at(r, c, b) as f64).collect();
        let lsf: Vec<f64> = (edge - w / 2..edge + w / 2)
            .map(|c| row[c] - row[c - 1])
            .collect();
        let total: f64 = lsf.iter().sum();
        for kf in 1..w / 2 {
            let (mut re, mut im) = (0.0, 0.0);
            for (i, v) in lsf.iter().enumerate() {
                let ph = -2.0 * PI * (kf * i) as f64 / w as f64;
                re += v * ph.cos();
                im += v * ph.sin();
            }
            let got = (re * re + im * im).sqrt() / total;
            let f_cyc_mm = kf as f64 / (w as f64 * dx) * 1e-3;
            let want = diffraction_mtf(f_cyc_mm, wl, n);
            worst = worst.max((got - want).abs());
            assert!(
                (got - want).abs() < 0.01,
                "{wl} nm, {f_cyc_mm:.0} cyc/mm: {got:.4} vs {want:.4}"
            );
        }
    }
    eprintln!("edge MTF vs diffraction MTF: max |error| = {worst:.5}");
}

fn rise_10_90(row: &[f64], lo: f64, hi: f64, dx: f64) -> f64 {
    let at = |level: f64| {
        let t = lo + level * (hi - lo);
        let i = row.iter().position(|v| *v >= t).unwrap();
        (i - 1) as f64 + (t - row[i - 1]) / (row[i] - row[i - 1])
    };
    (at(0.9) - at(0.1)) * dx
}

/// Depth-dependent defocus: a slanted edge at 50 cm (depth map), a diffraction-limited lens with
/// the Pixel 4a's f-number and focal length. Focus at 50 cm: the edge is sharp (10-90 % rise below
/// a micrometre, lambda N = 0.95 um). Focus at 30 cm: blurred by the thin-lens
/// circle of confusion c = (f/N)(v_s - v_o)/v_o = 15.0 um; a uniform disk of diameter c has a 10-90 %
/// edge rise of 0.61 c (the disk's edge-spread function, computed here by quadrature).
#[test]
fn slanted_edge_sharp_in_focus_blurred_out_of_focus() {
    let grid = WavelengthGrid::new(550.0, 550.0, 10.0).unwrap();
    let (f, n) = (4.38e-3f64, 1.73f64);
    let d = 0.5;
    let (rows, cols) = (160, 160);
    let mut rises = Vec::new();
    for focus in [0.5, 0.3] {
        let mut c = OpticsConfig::preset("diffraction-limited").unwrap();
        c.shading = ShadingConfig::Named(ShadingName::None);
        c.focus_distance_m = Some(focus);
        let o = Optics::from_config(&c).unwrap();
        let v_s = 1.0 / (1.0 / f - 1.0 / focus);
        // 0.25 um < lambda N / 2: the PSF is sampled, not cell-integrated, and the slanted edge's
        // staircase is small against the rise.
        let sensor_dx = 0.25e-6;
        let scene_dx = sensor_dx * d / v_s;
        let slope = (5f64).to_radians().tan();
        let mut img = image(rows, cols, grid, scene_dx, d, |_, r, c| {
            if (c as f64 - 80.0) > slope * (r as f64 - 80.0) {
                1.0
            } else {
                0.2
            }
        });
        img.depth_m = Some(vec![d as f32; rows * cols]);
        let out = o.compute(&img).unwrap();
        let pad = (out.rows - rows) / 2;
        let r = pad + 80;
        let row: Vec<f64> = (pad + 20..pad + 140)
            .map(|c| out.at(r, c, 0) as f64)
            .collect();
        let k = PI / (1.0 + 4.0 * n * n * (1.0 + lens_m(f, d)).powi(2));
        rises.push(
            rise_10_90(&row, 0.2 * k, 1.0 * k, out.sample_spacing_m) * (5f64).to_radians().cos(),
        );
    }
    // Disk ESF: fraction of a unit disk left of x: F(x) = (x sqrt(1-x^2) + asin x)/pi + 1/2.
    let esf = |x: f64| (x * (1.0 - x * x).sqrt() + x.asin()) / PI + 0.5;
    let inv = |p: f64| {
        let (mut lo, mut hi) = (-1.0, 1.0);
        for _ in 0..60 {
            let m = 0.5 * (lo + hi);
            if esf(m) < p {
                lo = m
            } else {
                hi = m
            }
        }
        lo
    };
    let vs = 1.0 / (1.0 / f - 1.0 / 0.3);
    let vo = 1.0 / (1.0 / f - 1.0 / d);
    let coc = f / n * (vs - vo) / vo;
    let disk_rise = (inv(0.9) - inv(0.1)) * coc / 2.0;
    eprintln!("edge 10-90% rise: in focus {:.2} um, focus 30 cm {:.2} um (disk of c = {:.2} um: {:.2} um)", rises[0] * 1e6, rises[1] * 1e6, coc * 1e6, disk_rise * 1e6);
    // The edge-spread function from an analytic OTF (real: the PSFs are symmetric),
    // ESF(x) = 1/2 + (1/pi) int_0^fc OTF(f) sin(2 pi f x) / f df (Simpson quadrature), fc = 1/(lambda N_w).
    // In focus: the diffraction-limited OTF (Goodman eq. 6-32); focus at 30 cm: Hopkins' defocus
    // OTF for W020 = 2 sqrt(3) c4, c4 the thin-lens focus error over the pupil.
    let esf_rise = |lam_nw: f64, otf: &dyn Fn(f64) -> f64, span: f64| {
        let fc = 1.0 / lam_nw;
        let m = 2000;
        let h = fc / m as f64;
        let table: Vec<f64> = (0..=m).map(|k| otf(k as f64 / m as f64)).collect();
        let esf = |x: f64| {
            let g = |k: usize| {
                let fr = k as f64 * h;
                if k == 0 {
                    2.0 * PI * x
                } else {
                    table[k] * (2.0 * PI * fr * x).sin() / fr
                }
            };
            let mut sum = g(0) + g(m);
            for k in 1..m {
                sum += g(k) * if k % 2 == 1 { 4.0 } else { 2.0 };
            }
            0.5 + sum * h / 3.0 / PI
        };
        // Level crossings on a fine scan (the defocused ESF ripples), linear between scan points.
        let xs: Vec<f64> = (0..=1000)
            .map(|i| -span + 2.0 * span * i as f64 / 1000.0)
            .collect();
        let e: Vec<f64> = xs.iter().map(|x| esf(*x)).collect();
        let cross = |p: f64| {
            let i = e.iter().position(|v| *v >= p).unwrap();
            xs[i - 1] + (p - e[i - 1]) / (e[i] - e[i - 1]) * (xs[i] - xs[i - 1])
        };
        cross(0.9) - cross(0.1)
    };
    let lam_n_in = 550e-9 * n * (1.0 + lens_m(f, d));
    let dl_rise = esf_rise(
        lam_n_in,
        &camsim_optics::lens::diffraction_mtf_normalized,
        5.0 * lam_n_in,
    );
    let lam_n_out = 550e-9 * n * vs / f;
    let c4_um = camsim_optics::lens::defocus_c4_um(f, n, 0.3, d);
    let w020_waves = 2.0 * 3f64.sqrt() * c4_um / 0.55;
    let defocus_rise = esf_rise(lam_n_out, &|s| hopkins_otf(s, w020_waves), coc);
    eprintln!("analytic ESF 10-90% rise: diffraction-limited {:.3} um, Hopkins defocus ({w020_waves:.2} waves) {:.3} um", dl_rise * 1e6, defocus_rise * 1e6);
    // Tolerances: the rises are read off 0.25 um samples by linear interpolation between the two
    // samples around each level, an error of up to ~1/8 of a sample at each crossing for an ESF
    // curving over ~lambda N (2 x 0.03 um on the 1.3 um in-focus rise: 5 %), and the 5 degree
    // staircase edge moves by one sample every 11.4 rows, which the ~8-row PSF averages into
    // < 0.03 um of extra rise. The sampled pupil's OTF is within 0.01 of the analytic ones
    // (tests/wavefront.rs), which moves the ESF by up to ~3 % of the step, i.e. the crossings by
    // up to ~4 % of the rise. In focus: 8 %; the 10 um defocused rise: 5 %.
    assert!(
        (rises[0] / dl_rise - 1.0).abs() < 0.08,
        "in-focus rise {} vs diffraction-limited {}",
        rises[0],
        dl_rise
    );
    assert!(
        (rises[1] / defocus_rise - 1.0).abs() < 0.05,
        "defocused rise {} vs Hopkins {}",
        rises[1],
        defocus_rise
    );
    // Geometric optics (the disk of the thin-lens circle of confusion) holds to the diffraction
    // spread lambda N_w against the rise.
    assert!(
        (rises[1] / disk_rise - 1.0).abs() < lam_n_out / disk_rise,
        "defocused rise {} vs disk {}",
        rises[1],
        disk_rise
    );
}

/// Hopkins (1955) defocus OTF (signed; real for a symmetric pupil) by quadrature:
/// OTF(s) = 4/(pi b) int_0^sqrt(1-s^2) sin(b (sqrt(1-y^2) - s)) dy, b = 8 pi W020 s / lambda.
fn hopkins_otf(s: f64, w020_over_lambda: f64) -> f64 {
    if s >= 1.0 {
        return 0.0;
    }
    let b = 8.0 * PI * w020_over_lambda * s;
    let ymax = (1.0 - s * s).sqrt();
    let n = 2000;
    let h = ymax / n as f64;
    let g = |y: f64| {
        let t = (1.0 - y * y).max(0.0).sqrt() - s;
        if b.abs() < 1e-12 {
            t
        } else {
            (b * t).sin() / b
        }
    };
    let mut sum = g(0.0) + g(ymax);
    for k in 1..n {
        sum += g(k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    4.0 / PI * sum * h / 3.0
}

fn lens_m(f: f64, d: f64) -> f64 {
    camsim_optics::lens::magnification(f, d)
}

/// A point in the focal plane gets the in-focus PSF: a scene whose left half lies at the focus
/// distance and right half at 0.3 m; a point in the left half (far from the depth boundary) blurs
/// exactly as with the shift-invariant in-focus optics.
#[test]
fn point_in_the_focal_plane_gets_the_in_focus_psf() {
    let grid = WavelengthGrid::new(500.0, 600.0, 100.0).unwrap();
    let (rows, cols) = (64, 200);
    let d = 1.0;
    let mk = |depth: bool| {
        let mut img = image(rows, cols, grid, 2e-6, d, |_, r, c| {
            if r == 32 && c == 40 {
                1.0
            } else {
                0.0
            }
        });
        if depth {
            img.depth_m = Some(
                (0..rows * cols)
                    .map(|i| if i % cols < 100 { d as f32 } else { 0.3 })
                    .collect(),
            );
        }
        img
    };
    let mut c = OpticsConfig::preset("pixel4a").unwrap();
    c.shading = ShadingConfig::Named(ShadingName::None);
    c.focus_distance_m = Some(d);
    let layered = Optics::from_config(&c).unwrap();
    let layers = layered
        .depth_layers(mk(true).depth_m.as_ref().unwrap(), cols, d)
        .unwrap();
    assert_eq!(layers.c4_um.len(), 2);
    assert!(layers.c4_um.contains(&0.0));
    let a = layered.compute(&mk(true)).unwrap();
    c.focus_distance_m = None;
    let flat = Optics::from_config(&c)
        .unwrap()
        .compute(&mk(false))
        .unwrap();
    // Kernel sizes differ (the defocused layer needs a bigger one): compare around the point.
    let (pa, pf) = ((a.rows - rows) / 2, (flat.rows - rows) / 2);
    let mut peak = 0.0f64;
    let mut maxdiff = 0.0f64;
    for b in 0..2 {
        for dr in -10i64..=10 {
            for dc in -10i64..=10 {
                let va = a.at(
                    (pa as i64 + 32 + dr) as usize,
                    (pa as i64 + 40 + dc) as usize,
                    b,
                ) as f64;
                let vf = flat.at(
                    (pf as i64 + 32 + dr) as usize,
                    (pf as i64 + 40 + dc) as usize,
                    b,
                ) as f64;
                peak = peak.max(vf);
                maxdiff = maxdiff.max((va - vf).abs());
            }
        }
    }
    assert!(maxdiff < 1e-3 * peak, "max diff {maxdiff} vs peak {peak}");
    // And the far layer is really defocused: a point there spreads more.
    assert!(layers.c4_um.iter().any(|c| *c < -0.3));
}

/// Layering respects the tolerance: each pixel's thin-lens c4 is within half a step of its layer's.
#[test]
fn depth_layers_respect_the_tolerance() {
    let mut c = OpticsConfig::preset("pixel4a").unwrap();
    c.defocus_tolerance_um = 0.02;
    let o = Optics::from_config(&c).unwrap();
    let depth: Vec<f32> = (0..1000).map(|i| 0.2 + i as f32 * 0.003).collect();
    let l = o.depth_layers(&depth, 1000, 0.5).unwrap();
    assert!((l.step_um - 0.02).abs() < 1e-12);
    for (i, d) in depth.iter().enumerate() {
        let c4 = o.defocus_c4_um(0.5, *d as f64);
        assert!((c4 - l.c4_um[l.index[i] as usize]).abs() <= 0.01 + 1e-12);
    }
    assert!(o.depth_layers(&[1.0, f32::NAN], 2, 0.5).is_err());
    assert!(o.depth_layers(&[1.0, 0.0], 2, 0.5).is_err());
}

/// ISETCam's blur (opticsOTF / oiCalculateOTF), written out independently of the crate's FFT
/// code: per band, the 2-D DFT (complex, rustfft) of the padded irradiance plane times the OTF at
/// the same frequencies (the DFT of the PSF periodized on the padded plane, whose DFT is checked
/// against the analytic cell-integrated OTF in tests/wavefront.rs), inverse DFT.
fn isetcam_otf_blur(plane: &[f64], rows: usize, cols: usize, psf_origin: &[f64]) -> Vec<f64> {
    use rustfft::num_complex::Complex64;
    let mut planner = rustfft::FftPlanner::<f64>::new();
    let fft2 =
        |data: &mut Vec<Complex64>, inverse: bool, planner: &mut rustfft::FftPlanner<f64>| {
            let (fr, fc) = if inverse {
                (
                    planner.plan_fft_inverse(cols),
                    planner.plan_fft_inverse(rows),
                )
            } else {
                (
                    planner.plan_fft_forward(cols),
                    planner.plan_fft_forward(rows),
                )
            };
            for row in data.chunks_exact_mut(cols) {
                fr.process(row);
            }
            let mut col = vec![Complex64::new(0.0, 0.0); rows];
            for c in 0..cols {
                (0..rows).for_each(|r| col[r] = data[r * cols + c]);
                fc.process(&mut col);
                (0..rows).for_each(|r| data[r * cols + c] = col[r]);
            }
        };
    let mut img: Vec<Complex64> = plane.iter().map(|v| Complex64::new(*v, 0.0)).collect();
    let mut otf: Vec<Complex64> = psf_origin.iter().map(|v| Complex64::new(*v, 0.0)).collect();
    fft2(&mut img, false, &mut planner);
    fft2(&mut otf, false, &mut planner);
    img.iter_mut().zip(&otf).for_each(|(a, b)| *a *= *b);
    fft2(&mut img, true, &mut planner);
    img.iter().map(|v| v.re / (rows * cols) as f64).collect()
}

/// Worst patch-mean errors (fractions) of a chart blurred by camsim against the reference.
struct ChartErrors {
    /// `psf.method = "auto"` (the default).
    default: f64,
    /// `psf.method = "kernel"` with the far tail (the default for kernels).
    kernel: f64,
    /// `psf.method = "kernel"` without the far tail (`psf.far_tail = false`).
    kernel_trimmed: f64,
    /// ISETCam's own padding (the output's PSF margin): light wraps around.
    wrapped: f64,
}

/// A ColorChecker-like chart (4 x 6 patches of `ps` samples at the Pixel 4a's 1.4 um pitch inside
/// a white border of `border` samples; reflectance 3 % to 90 %, patch 9 "blue": bright in band 0,
/// dark in band 1), pixel4a optics at infinity, no shading.
/// Reference: ISETCam's whole-image OTF blur ([`isetcam_otf_blur`]) of the chart on a zero-padded
/// plane `extra` samples larger per side than the default output, so little or no light wraps
/// around (then it is the linear convolution with the untrimmed PSF of the sampled pupil); it
/// conserves energy exactly (OTF(0) = 1; checked to 1e-9). Compares each patch's interior mean
/// (`ps / 6` samples in from its edges) in both bands; every output sample must be non-negative.
fn chart_errors(
    grid: WavelengthGrid,
    ps: usize,
    border: usize,
    extra_per_side: impl Fn(usize) -> usize,
) -> ChartErrors {
    assert_eq!(grid.len(), 2);
    let (pr, pc) = (4usize, 6usize);
    let (rows, cols) = (pr * ps + 2 * border, pc * ps + 2 * border);
    let refl = [
        0.31, 0.90, 0.59, 0.36, 0.19, 0.031, 0.45, 0.12, 0.70, 0.05, 0.25, 0.62, 0.09, 0.80, 0.40,
        0.15, 0.55, 0.08, 0.66, 0.28, 0.033, 0.90, 0.21, 0.48,
    ];
    let value = |b: usize, r: usize, c: usize| -> f32 {
        if r < border || c < border || r >= rows - border || c >= cols - border {
            return 0.9;
        }
        let k = (r - border) / ps * pc + (c - border) / ps;
        if k == 9 {
            // The blue patch: bright in band 0, dark in band 1.
            return if b == 0 { 0.35 } else { 0.04 };
        }
        refl[k] as f32
    };
    let f_mm = 4.38;
    let mut img = image(rows, cols, grid, 1e-6, 0.0, value);
    img.geometry.fov_deg = 2.0
        * (cols as f64 * 1.4e-6 / 2.0 / (f_mm * 1e-3))
            .atan()
            .to_degrees();
    let mut c = OpticsConfig::preset("pixel4a").unwrap();
    c.shading = ShadingConfig::Named(ShadingName::None);
    let optics = Optics::from_config(&c).unwrap();
    let default = optics.compute(&img).unwrap();
    c.psf.method = BlurMethod::Kernel;
    let kernel = Optics::from_config(&c).unwrap().compute(&img).unwrap();
    c.psf.far_tail = false;
    let trimmed = Optics::from_config(&c).unwrap().compute(&img).unwrap();
    for o in [&default, &kernel, &trimmed] {
        assert!(o.data.iter().all(|v| *v >= 0.0), "negative irradiance");
        assert_eq!((o.rows, o.cols), (default.rows, default.cols));
    }
    // ISETCam's blur of the chart on an FFT plane of the output grown by `extra` zeros per side.
    // Returns the plane's bands and its side lengths.
    let otf_blur = |extra: usize| {
        let (fr, fc) = (default.rows + 2 * extra, default.cols + 2 * extra);
        let (pr0, pc0) = ((fr - rows) / 2, (fc - cols) / 2);
        let bands: Vec<Vec<f64>> = (0..grid.len())
            .map(|b| {
                let wl = grid.wavelength_nm(b);
                // Scene at infinity: magnification 0 in the camera equation.
                let e = camsim_optics::lens::irradiance_factor(
                    c.f_number,
                    0.0,
                    optics.transmittance(wl),
                );
                let mut plane = vec![0.0f64; fr * fc];
                for r in 0..rows {
                    for cc in 0..cols {
                        plane[(r + pr0) * fc + cc + pc0] = value(b, r, cc) as f64 * e;
                    }
                }
                let psf = optics
                    .wavefront()
                    .psf_periodic(wl, default.sample_spacing_m, fr, fc, c.psf.oversampling)
                    .unwrap();
                let out = isetcam_otf_blur(&plane, fr, fc, &psf);
                let (si, so) = (plane.iter().sum::<f64>(), out.iter().sum::<f64>());
                assert!(
                    (so / si - 1.0).abs() < 1e-9,
                    "reference blur does not conserve energy: {so} vs {si}"
                );
                out
            })
            .collect();
        (bands, fr, fc)
    };
    let (reference, out_rows, out_cols) = otf_blur(extra_per_side(default.rows.max(default.cols)));
    let (wrapped, _, wrapped_cols) = otf_blur(0);
    let (pad_r, pad_c) = ((out_rows - rows) / 2, (out_cols - cols) / 2);
    let (dpr, dpc) = ((default.rows - rows) / 2, (default.cols - cols) / 2);
    let inset = ps / 6;
    let mean = |get: &dyn Fn(usize, usize) -> f64, k: usize| {
        let (r0, c0) = (
            pad_r + border + (k / pc) * ps + inset,
            pad_c + border + (k % pc) * ps + inset,
        );
        let n = ps - 2 * inset;
        let mut s = 0.0f64;
        for r in r0..r0 + n {
            for cc in c0..c0 + n {
                s += get(r, cc);
            }
        }
        s / (n * n) as f64
    };
    let mut worst = ChartErrors {
        default: 0.0,
        kernel: 0.0,
        kernel_trimmed: 0.0,
        wrapped: 0.0,
    };
    let at = |o: &SpectralImage, r: usize, cc: usize, b: usize| {
        o.at(r + dpr - pad_r, cc + dpc - pad_c, b) as f64
    };
    for b in 0..2 {
        for k in 0..pr * pc {
            let want = mean(&|r, cc| reference[b][r * out_cols + cc], k);
            let err = |get: &dyn Fn(usize, usize) -> f64| mean(get, k) / want - 1.0;
            let e = err(&|r, cc| at(&default, r, cc, b));
            let ek = err(&|r, cc| at(&kernel, r, cc, b));
            let et = err(&|r, cc| at(&trimmed, r, cc, b));
            let ew = err(&|r, cc| wrapped[b][(r + dpr - pad_r) * wrapped_cols + cc + dpc - pad_c]);
            let v = value(b, border + (k / pc) * ps, border + (k % pc) * ps);
            eprintln!(
                "band {b}, patch {k:2} ({v:.3}): default {:+.4} %, kernel {:+.4} %, trimmed kernel {:+.4} %, ISETCam as is {:+.4} %",
                e * 100.0,
                ek * 100.0,
                et * 100.0,
                ew * 100.0
            );
            worst.default = worst.default.max(e.abs());
            worst.kernel = worst.kernel.max(ek.abs());
            worst.kernel_trimmed = worst.kernel_trimmed.max(et.abs());
            worst.wrapped = worst.wrapped.max(ew.abs());
        }
    }
    eprintln!(
        "chart {rows} x {cols} (output {} x {}): worst patch-mean error vs the OTF reference: default {:.4} %, kernel {:.4} %, \
         trimmed kernel {:.4} %, ISETCam as is {:.4} %",
        default.rows,
        default.cols,
        worst.default * 100.0,
        worst.kernel * 100.0,
        worst.kernel_trimmed * 100.0,
        worst.wrapped * 100.0
    );
    worst
}

/// Issue 13 (and issue 1): a small chart (patches of 20 samples), where the default takes the
/// whole-image OTF route. Reference plane: zeros of twice the output's size on each side (period
/// 5x the output; the code uses 2x), so the light that leaves the chart does not wrap back onto it
/// (ISETCam's own small padding moves the dark corner patch by 0.7 %: printed as "ISETCam as
/// is"). The default must be within 0.2 % on every patch (the issue's target), and so must the
/// kernel route with its far tail; the trimmed, renormalized kernel (the former default) is
/// 0.48 % off here (dark corner patch next to the white border) and must stay worse than 0.3 %, or
/// this chart no longer shows what the far tail is for.
#[test]
fn chart_patch_means_match_the_isetcam_otf_blur() {
    let grid = WavelengthGrid::new(450.0, 650.0, 200.0).unwrap();
    let w = chart_errors(grid, 20, 4, |side| 2 * side);
    assert!(
        w.default < 2e-3,
        "default: worst patch mean error {:.3} %",
        w.default * 100.0
    );
    assert!(
        w.kernel < 2e-3,
        "kernel with far tail: worst patch mean error {:.3} %",
        w.kernel * 100.0
    );
    assert!(
        w.kernel_trimmed > 3e-3,
        "the trimmed kernel is only {:.3} % off",
        w.kernel_trimmed * 100.0
    );
}

/// Issue 13: a chart whose output is too large for the whole-image OTF route (patches of 60
/// samples, output over 400 samples), so the default blurs with kernels plus the far tail; it must
/// be within 0.2 % of the OTF reference on every patch. Reference plane: the output plus half its
/// size on each side (the PSF grid at 3x oversampling stays under 4000 samples; the light that
/// wraps is under 0.04 % of it, beyond 0.6 mm). Bands 550 and 650 nm keep the oversampling at 3.
#[test]
fn large_chart_patch_means_match_the_otf_blur_with_the_far_tail() {
    let grid = WavelengthGrid::new(550.0, 650.0, 100.0).unwrap();
    let w = chart_errors(grid, 60, 12, |side| side / 2);
    assert!(
        w.default < 2e-3,
        "default: worst patch mean error {:.3} %",
        w.default * 100.0
    );
    assert!(
        (w.default - w.kernel).abs() < 1e-12,
        "the default is not the kernel route here"
    );
    assert!(
        w.kernel_trimmed > 2.0 * w.default,
        "trimmed kernel {:.3} % vs default {:.3} %",
        w.kernel_trimmed * 100.0,
        w.default * 100.0
    );
}
/// `psf.method = "otf"` refuses what it cannot do, with a message naming the key or the method:
/// a depth map (one PSF per depth layer) and an image too large for the periodic PSF grid.
#[test]
fn otf_method_refuses_depth_maps_and_huge_images() {
    let grid = WavelengthGrid::new(550.0, 550.0, 10.0).unwrap();
    let mut c = OpticsConfig::preset("pixel4a").unwrap();
    c.psf.method = BlurMethod::Otf;
    c.focus_distance_m = Some(0.5);
    let o = Optics::from_config(&c).unwrap();
    let mut img = image(16, 16, grid, 1e-6, 0.5, |_, _, _| 1.0);
    img.depth_m = Some(vec![0.5; 16 * 16]);
    let e = o.compute(&img).unwrap_err().to_string();
    assert!(e.contains("psf.method"), "{e}");
    // 3000 samples at 1.4 um need 5x oversampling at 550 nm: a 30000-sample grid.
    c.focus_distance_m = None;
    let o = Optics::from_config(&c).unwrap();
    let mut img = image(8, 3000, grid, 1.4e-6, 0.0, |_, _, _| 1.0);
    img.geometry.fov_deg = 2.0 * (3000.0 * 1.4e-6 / 2.0 / 4.38e-3f64).atan().to_degrees();
    let e = o.compute(&img).unwrap_err().to_string();
    assert!(e.contains("psf.method"), "{e}");
}
