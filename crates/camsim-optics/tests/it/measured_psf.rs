//! Measured PSFs (`blur.measured_psf`, issue 42 item 4) against closed forms: Gaussian PSFs
//! measured at two field heights and two wavelengths. A mixture of zero-mean PSFs has the mixed
//! second moments, so a point's image at field height h and wavelength wl has the radial and
//! tangential variances of the measurements interpolated linearly in h and wl; its long axis lies
//! along its own radius at every azimuth (the measurement is along +x), and its centroid stays on
//! the point. Bad files and keys are errors naming them.

use camsim_core::image::ImageGeometry;
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_optics::config::{
    BlurConfig, BlurKind, BlurMethod, MeasuredPsfConfig, MeasuredPsfFile, ShadingConfig,
    ShadingName,
};
use camsim_optics::{Optics, OpticsConfig};
use std::path::Path;

const FILE_SPACING_UM: f64 = 0.5;
const FILE_SIDE: usize = 81;
/// Measured heights, um, and per height and band (500, 600 nm) the radial and tangential sigma, um.
const HEIGHTS_UM: [f64; 2] = [0.0, 200.0];
const SIGMAS_UM: [[[f64; 2]; 2]; 2] = [[[1.5, 1.5], [2.5, 2.5]], [[3.0, 1.5], [4.0, 2.5]]];

/// An anisotropic Gaussian PSF file (columns radial, rows tangential) at 500 and 600 nm.
fn write_psf(path: &Path, sigmas_um: [[f64; 2]; 2]) {
    let grid = WavelengthGrid::new(500.0, 600.0, 100.0).unwrap();
    let n = FILE_SIDE;
    let mid = (n - 1) as f64 / 2.0;
    let mut data = vec![0.0f32; 2 * n * n];
    for (b, [sr, st]) in sigmas_um.iter().enumerate() {
        for r in 0..n {
            for c in 0..n {
                let (x, y) = (
                    (c as f64 - mid) * FILE_SPACING_UM,
                    (r as f64 - mid) * FILE_SPACING_UM,
                );
                data[(b * n + r) * n + c] =
                    (-0.5 * (x * x / (sr * sr) + y * y / (st * st))).exp() as f32;
            }
        }
    }
    let img = SpectralImage::from_data(
        n,
        n,
        grid,
        FILE_SPACING_UM * 1e-6,
        Quantity::Irradiance,
        data,
    )
    .unwrap();
    camsim_io::exr::write_spectral_exr(path, &img, "psf").unwrap();
}

fn config(dir: &Path) -> OpticsConfig {
    let mut files = Vec::new();
    for (i, h) in HEIGHTS_UM.iter().enumerate() {
        let p = dir.join(format!("psf_{i}.exr"));
        write_psf(&p, SIGMAS_UM[i]);
        files.push(MeasuredPsfFile {
            field_height_mm: h * 1e-3,
            file: p,
        });
    }
    with_files(files)
}

/// The test's optics with measured PSFs from `files`.
fn with_files(files: Vec<MeasuredPsfFile>) -> OpticsConfig {
    let mut c = OpticsConfig::preset("diffraction-limited").unwrap();
    c.f_number = 2.8;
    c.focal_length_mm = 4.38;
    c.shading = ShadingConfig::Named(ShadingName::None);
    c.psf.method = BlurMethod::Kernel;
    c.psf.far_tail = false;
    c.blur = Some(BlurConfig {
        method: BlurKind::ShiftVariant,
        field_heights: 8,
        block_px: Some(8),
        rotation_oversampling: 3,
        lens_file: None,
        rtf_file: None,
        field_zernike: None,
        measured_psf: Some(MeasuredPsfConfig {
            spacing_um: None,
            files,
        }),
        ghosts: None,
    });
    c
}

/// Centroid and the variances along and across the azimuth `az` (radians) of the window of
/// `radius` around (r0, c0), px and px^2.
fn moments(data: &[f32], cols: usize, r0: usize, c0: usize, radius: usize, az: f64) -> [f64; 4] {
    let (mut s, mut sr, mut sc) = (0.0, 0.0, 0.0);
    let win = || {
        (r0 - radius..=r0 + radius).flat_map(|r| (c0 - radius..=c0 + radius).map(move |c| (r, c)))
    };
    for (r, c) in win() {
        let v = data[r * cols + c] as f64;
        s += v;
        sr += v * r as f64;
        sc += v * c as f64;
    }
    let (mr, mc) = (sr / s, sc / s);
    let (ca, sa) = (az.cos(), az.sin());
    let (mut vr, mut vt) = (0.0, 0.0);
    for (r, c) in win() {
        let v = data[r * cols + c] as f64;
        let (dx, dy) = (c as f64 - mc, r as f64 - mr);
        let along = dx * ca + dy * sa;
        let across = -dx * sa + dy * ca;
        vr += v * along * along;
        vt += v * across * across;
    }
    [mr, mc, vr / s, vt / s]
}

#[test]
fn measured_psfs_interpolate_in_field_and_wavelength_and_turn_with_the_azimuth() {
    let dir = tempfile::tempdir().unwrap();
    let o = Optics::from_config(&config(dir.path())).unwrap();
    // One band at 550 nm: halfway between the files' bands.
    let grid = WavelengthGrid::new(550.0, 550.0, 10.0).unwrap();
    let (rows, cols) = (257usize, 257usize);
    let spacing_m = 1.0e-6;
    let mut worst = 0.0f64;
    let mut totals: Option<f64> = None;
    for (radius_px, az_deg) in [
        (0.0, 0.0),
        (96.0, 0.0f64),
        (96.0, 45.0),
        (96.0, 90.0),
        (64.0, -135.0),
    ] {
        let (pr, pc) = (
            (128.0 + radius_px * az_deg.to_radians().sin()).round() as usize,
            (128.0 + radius_px * az_deg.to_radians().cos()).round() as usize,
        );
        let mut data = vec![0.0f32; rows * cols];
        data[pr * cols + pc] = 1.0;
        let mut img =
            SpectralImage::from_data(rows, cols, grid, spacing_m, Quantity::Radiance, data)
                .unwrap();
        img.geometry = ImageGeometry {
            fov_deg: 2.0
                * (cols as f64 * spacing_m / 2.0 / 4.38e-3)
                    .atan()
                    .to_degrees(),
            distance_m: 0.0,
            focal_length_m: 0.0,
            f_number: 0.0,
        };
        let out = o.compute(&img).unwrap();
        let pad = (out.rows - rows) / 2;
        // The point's own field position (sample centres; the axis between samples 127 and 128
        // of 257 lies at 128.5 in edge coordinates, i.e. sample 128).
        let (dy, dx) = (pr as f64 - 128.0, pc as f64 - 128.0);
        let h_um = dy.hypot(dx) * spacing_m * 1e6;
        let az = dy.atan2(dx);
        let [mr, mc, vr, vt] = moments(&out.data, out.cols, pr + pad, pc + pad, 24, az);
        // The closed form: variances linear in wavelength (550 nm: the mean of the bands) and
        // in field height, in px^2 (1 px = 1 um here).
        let u = h_um / HEIGHTS_UM[1];
        let var = |k: usize| {
            let at = |i: usize| 0.5 * (SIGMAS_UM[i][0][k].powi(2) + SIGMAS_UM[i][1][k].powi(2));
            (1.0 - u) * at(0) + u * at(1)
        };
        let (want_r, want_t) = (var(0), var(1));
        // Tolerance: the blocks' PSF is their centre's (8 px blocks: up to 5.7 px of field
        // height, 0.2 px^2 of radial variance here) and the sampling adds about 1/12 px^2.
        let tol = 0.3 + 0.03 * want_r;
        println!(
            "h {h_um:.1} um, azimuth {az_deg}: radial variance {vr:.3} px^2 (closed form {want_r:.3}), tangential {vt:.3} ({want_t:.3}); centroid off by ({:.3}, {:.3}) px",
            mr - (pr + pad) as f64,
            mc - (pc + pad) as f64
        );
        assert!(
            (vr - want_r).abs() < tol,
            "radial variance {vr} vs {want_r}"
        );
        assert!(
            (vt - want_t).abs() < tol,
            "tangential variance {vt} vs {want_t}"
        );
        assert!((mr - (pr + pad) as f64).abs() < 0.05 && (mc - (pc + pad) as f64).abs() < 0.05);
        worst = worst.max((vr - want_r).abs()).max((vt - want_t).abs());
        // Energy is kept (the PSFs are normalized; no shading): every point gives the same
        // irradiance sum, the on-axis point's.
        let total: f64 = out.data.iter().map(|&v| v as f64).sum();
        let first = *totals.get_or_insert(total);
        assert!(
            (total / first - 1.0).abs() < 1e-4,
            "energy {total} vs {first}"
        );
    }
    println!("worst variance error {worst:.3} px^2");
}

#[test]
fn bad_measured_psfs_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = config(dir.path());
    let err = |c: &OpticsConfig| match Optics::from_config(c) {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    };
    let set = |c: &mut OpticsConfig, f: &dyn Fn(&mut MeasuredPsfConfig)| {
        f(c.blur.as_mut().unwrap().measured_psf.as_mut().unwrap())
    };
    // Heights out of order.
    set(&mut c, &|m| m.files[1].field_height_mm = 0.0);
    let e = err(&c);
    assert!(e.contains("measured_psf.files[1].field_height_mm"), "{e}");
    // A missing file and a file that is not a spectral EXR.
    let mut c = config(dir.path());
    set(&mut c, &|m| {
        m.files[0].file = dir.path().join("nowhere.exr")
    });
    let e = err(&c);
    assert!(
        e.contains("measured_psf.files[0]") && e.contains("nowhere.exr"),
        "{e}"
    );
    std::fs::write(dir.path().join("text.exr"), "not an exr").unwrap();
    let mut c = config(dir.path());
    set(&mut c, &|m| m.files[1].file = dir.path().join("text.exr"));
    let e = err(&c);
    assert!(
        e.contains("measured_psf.files[1]") && e.contains("text.exr"),
        "{e}"
    );
    // A bad spacing; a PSF without energy.
    let mut c = config(dir.path());
    set(&mut c, &|m| m.spacing_um = Some(-1.0));
    assert!(err(&c).contains("measured_psf.spacing_um"));
    let grid = WavelengthGrid::new(500.0, 600.0, 100.0).unwrap();
    let dark =
        SpectralImage::from_data(3, 3, grid, 1e-6, Quantity::Irradiance, vec![0.0; 18]).unwrap();
    camsim_io::exr::write_spectral_exr(&dir.path().join("dark.exr"), &dark, "psf").unwrap();
    let mut c = config(dir.path());
    set(&mut c, &|m| m.files[0].file = dir.path().join("dark.exr"));
    let e = err(&c);
    assert!(e.contains("dark.exr") && e.contains("no energy"), "{e}");
    // With another PSF source, or the shift-invariant method.
    let mut c = config(dir.path());
    c.blur.as_mut().unwrap().rtf_file = Some(dir.path().join("x.json"));
    assert!(err(&c).contains("give one of"));
    let mut c = config(dir.path());
    c.blur.as_mut().unwrap().method = BlurKind::ShiftInvariant;
    assert!(err(&c).contains("measured_psf need method"));
}

/// The image of a unit point at `radius_px` from the centre of a 257 x 257 image of 1 um pixels,
/// at azimuth `az_deg`, through `o` at 550 nm: the window moments about the point
/// ([`moments`]) with the azimuth the point's own.
fn point_moments(o: &Optics, radius_px: f64, az_deg: f64) -> [f64; 4] {
    let grid = WavelengthGrid::new(550.0, 550.0, 10.0).unwrap();
    let (rows, cols) = (257usize, 257usize);
    let spacing_m = 1.0e-6;
    let (pr, pc) = (
        (128.0 + radius_px * az_deg.to_radians().sin()).round() as usize,
        (128.0 + radius_px * az_deg.to_radians().cos()).round() as usize,
    );
    let mut data = vec![0.0f32; rows * cols];
    data[pr * cols + pc] = 1.0;
    let mut img =
        SpectralImage::from_data(rows, cols, grid, spacing_m, Quantity::Radiance, data).unwrap();
    img.geometry = ImageGeometry {
        fov_deg: 2.0
            * (cols as f64 * spacing_m / 2.0 / 4.38e-3)
                .atan()
                .to_degrees(),
        distance_m: 0.0,
        focal_length_m: 0.0,
        f_number: 0.0,
    };
    let out = o.compute(&img).unwrap();
    let pad = (out.rows - rows) / 2;
    let az = (pr as f64 - 128.0).atan2(pc as f64 - 128.0);
    let [mr, mc, vr, vt] = moments(&out.data, out.cols, pr + pad, pc + pad, 24, az);
    [mr - (pr + pad) as f64, mc - (pc + pad) as f64, vr, vt]
}

#[test]
fn a_bench_mtf_table_gives_its_gaussian_psf() {
    // A Gaussian PSF of sigma s has the MTF exp(-2 pi^2 s^2 f^2) along each axis (the Fourier
    // transform of a Gaussian): a table of it, tangential sigma 3 um and sagittal 1.5 um, to
    // 500 cycles/mm in 10 cycles/mm steps, in percent, must give back the PSF: radial variance
    // 9 um^2, tangential 2.25 um^2 (1 px = 1 um here), on every radius.
    let (st_mm, ss_mm) = (3.0e-3, 1.5e-3);
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("mtf.csv");
    let mut text =
        String::from("# Gaussian lens\nfrequency_cy_per_mm,tangential_percent,sagittal_percent\n");
    for i in 0..=50 {
        let f = 10.0 * i as f64;
        let g = |s: f64| 100.0 * (-2.0 * std::f64::consts::PI.powi(2) * s * s * f * f).exp();
        text += &format!("{f},{:.6},{:.6}\n", g(st_mm), g(ss_mm));
    }
    std::fs::write(&p, text).unwrap();
    let o = Optics::from_config(&with_files(vec![MeasuredPsfFile {
        field_height_mm: 0.0,
        file: p,
    }]))
    .unwrap();
    let (want_r, want_t) = (9.0, 2.25);
    for (radius_px, az_deg) in [(96.0, 0.0), (96.0, 90.0), (64.0, -135.0)] {
        let [dr, dc, vr, vt] = point_moments(&o, radius_px, az_deg);
        println!(
            "radius {radius_px} px, azimuth {az_deg}: radial variance {vr:.3} px^2 ({want_r}), tangential {vt:.3} ({want_t}), centroid off by ({dr:.3}, {dc:.3}) px"
        );
        // The pixel sampling adds about 1/12 px^2; the rotation's resampling a little more.
        let tol = 0.35;
        assert!(
            (vr - want_r).abs() < tol,
            "radial variance {vr} vs {want_r}"
        );
        assert!(
            (vt - want_t).abs() < tol,
            "tangential variance {vt} vs {want_t}"
        );
        assert!(dr.abs() < 0.05 && dc.abs() < 0.05, "centroid ({dr}, {dc})");
    }
    // A table without its sagittal column is named.
    let bad = dir.path().join("tan_only.csv");
    std::fs::write(&bad, "frequency_cy_per_mm,tangential\n0,1\n100,0.5\n").unwrap();
    let Err(e) = Optics::from_config(&with_files(vec![MeasuredPsfFile {
        field_height_mm: 0.0,
        file: bad,
    }])) else {
        panic!("a table without its sagittal column was accepted");
    };
    let e = e.to_string();
    assert!(
        e.contains("measured_psf.files[0]") && e.contains("tan_only.csv") && e.contains("sagittal"),
        "{e}"
    );
}

/// With phase columns (a bench's PTF): the Gaussian table of `a_bench_mtf_table_gives_its_gaussian_psf`
/// with a tangential PTF of -360 f x0 degrees (Goodman's sign: a line spread function displaced
/// by +x0) moves every point's image outward along its radius by x0 = 2 um (2 px), its widths
/// unchanged; a sagittal PTF of the same slope moves it along the tangent instead (toward
/// increasing azimuth, the image's turn from +x to +y).
#[test]
fn a_bench_ptf_moves_the_psf_by_its_slope() {
    let (st_mm, ss_mm, x0_mm) = (3.0e-3, 1.5e-3, 2.0e-3);
    let dir = tempfile::tempdir().unwrap();
    let optics_of = |tan_phase: bool| {
        let p = dir.path().join(format!("ptf_{tan_phase}.csv"));
        let mut text = String::from(
            "frequency_cy_per_mm,tangential_percent,sagittal_percent,tangential_phase_deg,sagittal_ptf_deg\n",
        );
        for i in 0..=50 {
            let f = 10.0 * i as f64;
            let g = |s: f64| 100.0 * (-2.0 * std::f64::consts::PI.powi(2) * s * s * f * f).exp();
            let ptf = -360.0 * f * x0_mm;
            let (tp, sp) = if tan_phase { (ptf, 0.0) } else { (0.0, ptf) };
            text += &format!("{f},{:.6},{:.6},{tp},{sp}\n", g(st_mm), g(ss_mm));
        }
        std::fs::write(&p, text).unwrap();
        Optics::from_config(&with_files(vec![MeasuredPsfFile {
            field_height_mm: 0.0,
            file: p,
        }]))
        .unwrap()
    };
    let x0_px = x0_mm * 1e3;
    for tan_phase in [true, false] {
        let o = optics_of(tan_phase);
        for (radius_px, az_deg) in [(96.0, 0.0), (96.0, 90.0), (64.0, -135.0)] {
            let [dr, dc, vr, vt] = point_moments(&o, radius_px, az_deg);
            let az = f64::to_radians(az_deg);
            // Outward: (sin az, cos az) in (row, column); along the tangent: (cos az, -sin az)
            // turned a quarter toward +y.
            let want = if tan_phase {
                [x0_px * az.sin(), x0_px * az.cos()]
            } else {
                [x0_px * az.cos(), -x0_px * az.sin()]
            };
            println!(
                "{} PTF, radius {radius_px} px, azimuth {az_deg}: centroid moved ({dr:.3}, {dc:.3}) px, closed form ({:.3}, {:.3}); variances {vr:.3}, {vt:.3}",
                if tan_phase { "tangential" } else { "sagittal" },
                want[0],
                want[1]
            );
            assert!(
                (dr - want[0]).hypot(dc - want[1]) < 0.1,
                "moved ({dr}, {dc}), want {want:?}"
            );
            assert!(
                (vr - 9.0).abs() < 0.35 && (vt - 2.25).abs() < 0.35,
                "{vr} {vt}"
            );
        }
    }
}
