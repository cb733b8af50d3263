//! Shift-variant ("ray-trace") optics: consistency with the shift-invariant blur, energy
//! conservation, PSF rotation to the block azimuth, a traced lens's diffraction limit, wavefront
//! sign, distortion and relative illumination, and clear errors.

use camsim_core::image::ImageGeometry;
use camsim_core::{Quantity, SpectralImage, WavelengthGrid};
use camsim_optics::config::{
    BlurConfig, BlurKind, BlurMethod, FieldZernikeConfig, ShadingConfig, ShadingName, ZernikeTerms,
};
use camsim_optics::traced::{ObjectField, TracedLens};
use camsim_optics::{diffraction_mtf, Optics, OpticsConfig, Wavefront};
use std::path::PathBuf;

fn lens_path(name: &str) -> PathBuf {
    PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/isetcornellbox/lens"
    ))
    .join(name)
}

fn config(n: f64, f_mm: f64) -> OpticsConfig {
    let mut c = OpticsConfig::preset("diffraction-limited").unwrap();
    c.f_number = n;
    c.focal_length_mm = f_mm;
    c.shading = ShadingConfig::Named(ShadingName::None);
    c.psf.method = BlurMethod::Kernel;
    c.psf.far_tail = false;
    c
}

fn sv(field_heights: usize, block_px: Option<usize>) -> BlurConfig {
    BlurConfig {
        method: BlurKind::ShiftVariant,
        field_heights,
        block_px,
        rotation_oversampling: 3,
        lens_file: None,
        rtf_file: None,
        field_zernike: None,
        measured_psf: None,
        ghosts: None,
    }
}

/// A radiance image at `distance_m` (0: infinity, then `fov_deg` sets the sampling).
fn image(
    rows: usize,
    cols: usize,
    grid: WavelengthGrid,
    spacing_m: f64,
    distance_m: f64,
    fov_deg: f64,
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
        fov_deg,
        distance_m,
        focal_length_m: 0.0,
        f_number: 0.0,
    };
    img
}

fn pattern(b: usize, r: usize, c: usize) -> f32 {
    let h = (r.wrapping_mul(7919) ^ c.wrapping_mul(104729) ^ b.wrapping_mul(31)) % 997;
    0.2 + (h as f32 / 997.0)
        + if (r / 9 + c / 13).is_multiple_of(2) {
            1.0
        } else {
            0.0
        }
}

/// (i) A field-independent, rotationally symmetric wavefront: the shift-variant stage must give
/// the shift-invariant tiled blur (same kernels) to float round-off, with its own tiles and with
/// a different block size (other seams).
#[test]
fn field_independent_terms_match_the_shift_invariant_blur() {
    let grid = WavelengthGrid::new(450.0, 650.0, 100.0).unwrap();
    let mut c = config(2.8, 4.38);
    c.wavefront.zernike_um = ZernikeTerms::Indexed(vec![
        0.0, 0.0, 0.0, 0.0, 0.15, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.08,
    ]);
    let img = image(
        150,
        170,
        grid,
        1.2e-6,
        0.0,
        2.0 * (170.0 * 1.2e-6 / 2.0 / 4.38e-3f64).atan().to_degrees(),
        pattern,
    );
    let reference = Optics::from_config(&c).unwrap().compute(&img).unwrap();
    let peak = reference.data.iter().cloned().fold(0.0f32, f32::max);
    for block in [None, Some(40)] {
        let mut cs = c.clone();
        cs.blur = Some(sv(8, block));
        let out = Optics::from_config(&cs).unwrap().compute(&img).unwrap();
        assert_eq!((out.rows, out.cols), (reference.rows, reference.cols));
        let err = out
            .data
            .iter()
            .zip(&reference.data)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max)
            / peak;
        println!("block {block:?}: max |shift-variant - shift-invariant| / peak = {err:.2e}");
        assert!(err < 2e-6, "block {block:?}: relative error {err}");
    }
}

fn astig_table(c5_um: f64) -> FieldZernikeConfig {
    // Local frame (x radial): c4 = c5 / sqrt(2) cancels the y curvature (W = 2 sqrt(6) c5 x^2),
    // so the PSF is a line along x, the radial direction; it grows with field height.
    let row = |s: f64| {
        let mut v = vec![0.0; 6];
        v[4] = s * c5_um / 2f64.sqrt();
        v[5] = s * c5_um;
        v
    };
    FieldZernikeConfig {
        field_height_mm: None,
        field_height_normalized: Some(vec![0.0, 0.3, 1.0]),
        zernike_um: vec![row(0.0), row(1.0), row(1.0)],
    }
}

/// (ii) Energy: each block's kernel has unit sum, so the blurred image keeps the camera
/// equation's total (no shading, padding holds all the blurred light), with rotation and
/// field-height interpolation on.
#[test]
fn shift_variant_blur_conserves_energy() {
    let grid = WavelengthGrid::new(450.0, 650.0, 100.0).unwrap();
    let mut c = config(2.8, 4.38);
    let mut b = sv(6, Some(24));
    b.field_zernike = Some(astig_table(0.4));
    c.blur = Some(b);
    let img = image(
        120,
        140,
        grid,
        1.2e-6,
        0.0,
        2.0 * (140.0 * 1.2e-6 / 2.0 / 4.38e-3f64).atan().to_degrees(),
        pattern,
    );
    let o = Optics::from_config(&c).unwrap();
    let out = o.compute(&img).unwrap();
    let factor = camsim_optics::lens::irradiance_factor(2.8, 0.0, 1.0);
    for band in 0..grid.len() {
        let sin: f64 = img.data[band * 120 * 140..(band + 1) * 120 * 140]
            .iter()
            .map(|v| *v as f64)
            .sum::<f64>()
            * factor;
        let n = out.rows * out.cols;
        let sout: f64 = out.data[band * n..(band + 1) * n]
            .iter()
            .map(|v| *v as f64)
            .sum();
        let rel = (sout / sin - 1.0).abs();
        println!("band {band}: relative energy change {rel:.2e}");
        assert!(rel < 1e-4, "band {band}: {rel}");
        assert!(out.data.iter().all(|v| v.is_finite()));
    }
}

/// Second moments of the light around (r0, c0) within `radius` samples: (centroid row, centroid
/// col, angle of the long axis from +x (columns) toward +y (rows), degrees, elongation ratio).
fn moments(data: &[f32], cols: usize, r0: usize, c0: usize, radius: usize) -> (f64, f64, f64, f64) {
    let (mut s, mut sr, mut sc) = (0.0, 0.0, 0.0);
    for r in r0 - radius..=r0 + radius {
        for c in c0 - radius..=c0 + radius {
            let v = data[r * cols + c] as f64;
            s += v;
            sr += v * r as f64;
            sc += v * c as f64;
        }
    }
    let (mr, mc) = (sr / s, sc / s);
    let (mut xx, mut yy, mut xy) = (0.0, 0.0, 0.0);
    for r in r0 - radius..=r0 + radius {
        for c in c0 - radius..=c0 + radius {
            let v = data[r * cols + c] as f64;
            let (dx, dy) = (c as f64 - mc, r as f64 - mr);
            xx += v * dx * dx;
            yy += v * dy * dy;
            xy += v * dx * dy;
        }
    }
    let angle = 0.5 * (2.0 * xy).atan2(xx - yy);
    let tr = xx + yy;
    let det = xx * yy - xy * xy;
    let l1 = tr / 2.0 + (tr * tr / 4.0 - det).max(0.0).sqrt();
    let l2 = tr / 2.0 - (tr * tr / 4.0 - det).max(0.0).sqrt();
    (mr, mc, angle.to_degrees(), (l1 / l2.max(1e-30)).sqrt())
}

/// (iii) The field PSF is rotated to the block's azimuth: an astigmatic line focus that lies along
/// the radius in the local frame has its long axis along the radius at 0, 45 and 90 degrees (and
/// -135), and the point's image stays centred on the point (no distortion in this model).
#[test]
fn psf_long_axis_follows_the_azimuth() {
    let grid = WavelengthGrid::new(550.0, 550.0, 10.0).unwrap();
    let (rows, cols) = (257usize, 257usize);
    let spacing = 1.0e-6;
    let mut c = config(2.8, 4.38);
    let mut b = sv(8, Some(16));
    b.field_zernike = Some(astig_table(0.5));
    c.blur = Some(b);
    let o = Optics::from_config(&c).unwrap();
    let radius_px = 96.0;
    for az_deg in [0.0f64, 45.0, 90.0, -135.0] {
        let (pr, pc) = (
            (128.0 + radius_px * az_deg.to_radians().sin()).round() as usize,
            (128.0 + radius_px * az_deg.to_radians().cos()).round() as usize,
        );
        let img = image(
            rows,
            cols,
            grid,
            spacing,
            0.0,
            2.0 * (cols as f64 * spacing / 2.0 / 4.38e-3).atan().to_degrees(),
            |_, r, cc| {
                if r == pr && cc == pc {
                    1.0
                } else {
                    0.0
                }
            },
        );
        let out = o.compute(&img).unwrap();
        let pad = (out.rows - rows) / 2;
        let (mr, mc, angle, elong) = moments(&out.data, out.cols, pr + pad, pc + pad, 12);
        // The point's own azimuth from the image centre (sample centres, axis at 128.5).
        let az_true = ((pr as f64 + 0.5 - 128.5).atan2(pc as f64 + 0.5 - 128.5)).to_degrees();
        let mut d = (angle - az_true).rem_euclid(180.0);
        if d > 90.0 {
            d = 180.0 - d;
        }
        println!(
            "azimuth {az_deg}: centroid ({:.3}, {:.3}) px off, long axis {angle:.1} deg (radius at {az_true:.1}), elongation {elong:.2}",
            mr - (pr + pad) as f64,
            mc - (pc + pad) as f64
        );
        assert!(
            elong > 2.0,
            "the astigmatic PSF is a line (elongation {elong})"
        );
        assert!(
            d < 8.0,
            "azimuth {az_deg}: long axis {angle} deg, radius {az_true} deg"
        );
        assert!((mr - (pr + pad) as f64).abs() < 0.05 && (mc - (pc + pad) as f64).abs() < 0.05);
    }
}

/// (iv) A traced double Gauss stopped down to f/8 is near diffraction-limited on the axis: the
/// MTF from its traced wavefront is within 0.03 of the Airy MTF (Goodman eq. 6-32).
#[test]
fn traced_lens_on_axis_is_diffraction_limited_at_small_aperture() {
    let t = TracedLens::from_file(&lens_path("dgauss.82deg.4.38mm.json"), 8.0, 4.38).unwrap();
    let cam = t.camera(f64::INFINITY, 8.0).unwrap();
    let c = t
        .wavefront_zernike_um(
            &cam,
            ObjectField::Infinity { tan_theta: 0.0 },
            &[550.0],
            [0.0, 0.0],
        )
        .unwrap()
        .remove(0);
    let rms_waves = c[1..].iter().map(|v| v * v).sum::<f64>().sqrt() / 0.55;
    let w = Wavefront::diffraction_limited(t.efl_mm * 1e-3, 8.0)
        .unwrap()
        .with_zernike(c, t.efl_mm * 1e-3 / 8.0)
        .unwrap();
    let m = w.mtf(550.0).unwrap();
    let cutoff = m.freq_cyc_per_mm.last().copied().unwrap();
    let mut worst: f64 = 0.0;
    for (f, v) in m.freq_cyc_per_mm.iter().zip(&m.mtf_x) {
        if *f > 0.05 * cutoff && *f < 0.9 * cutoff {
            worst = worst.max((v - diffraction_mtf(*f, 550.0, 8.0)).abs());
        }
    }
    println!(
        "dgauss f/8 on axis: rms wavefront {rms_waves:.4} waves, worst |MTF - Airy MTF| {worst:.4}"
    );
    assert!(
        rms_waves < 0.07,
        "Marechal criterion: rms {rms_waves} waves"
    );
    assert!(worst < 0.03, "MTF off the diffraction limit by {worst}");
}

/// The wavefront's sign and orientation: with the reference sphere moved by +delta along x, the
/// traced wavefront is a tilt that puts the PSF at -delta (the real focus) relative to it.
#[test]
fn traced_wavefront_tilt_moves_the_psf_to_the_real_focus() {
    let t = TracedLens::from_file(&lens_path("dgauss.82deg.4.38mm.json"), 8.0, 4.38).unwrap();
    let cam = t.camera(f64::INFINITY, 8.0).unwrap();
    let delta_mm = 0.004;
    for (dx, dy) in [(delta_mm, 0.0), (0.0, delta_mm)] {
        let c = t
            .wavefront_zernike_um(
                &cam,
                ObjectField::Infinity { tan_theta: 0.0 },
                &[550.0],
                [dx, dy],
            )
            .unwrap()
            .remove(0);
        let w = Wavefront::diffraction_limited(t.efl_mm * 1e-3, 8.0)
            .unwrap()
            .with_zernike(c, t.efl_mm * 1e-3 / 8.0)
            .unwrap()
            .with_image_distance(t.efl_mm * 1e-3);
        let spacing = 0.5e-6;
        let psf = w.psf(550.0, spacing, 61).unwrap();
        let (mut cx, mut cy) = (0.0, 0.0);
        for r in 0..61 {
            for cc in 0..61 {
                cx += psf.at(r, cc) * (cc as f64 - 30.0) * spacing * 1e3;
                cy += psf.at(r, cc) * (r as f64 - 30.0) * spacing * 1e3;
            }
        }
        println!("reference moved by ({dx}, {dy}) mm: PSF centroid ({cx:.5}, {cy:.5}) mm");
        assert!(
            (cx + dx).abs() < 0.1 * delta_mm && (cy + dy).abs() < 0.1 * delta_mm,
            "centroid ({cx}, {cy}) for offset ({dx}, {dy})"
        );
    }
}

fn lens_config(n: f64) -> OpticsConfig {
    let mut c = config(n, 4.38);
    let mut b = sv(8, None);
    b.lens_file = Some(lens_path("dgauss.82deg.4.38mm.json"));
    c.blur = Some(b);
    c
}

/// (iii) Distortion: a point source off the axis lands where the lens's 550 nm chief ray meets
/// the film (not at its ideal, rectilinear position).
#[test]
fn point_source_lands_on_the_chief_ray() {
    let grid = WavelengthGrid::new(550.0, 550.0, 10.0).unwrap();
    let (rows, cols, spacing, f) = (301usize, 401usize, 8e-6, 4.38e-3);
    let fov = 2.0 * (cols as f64 * spacing / 2.0 / f).atan().to_degrees();
    let o = Optics::from_config(&lens_config(8.0)).unwrap();
    let t = TracedLens::from_file(&lens_path("dgauss.82deg.4.38mm.json"), 8.0, 4.38).unwrap();
    let cam = t.camera(f64::INFINITY, 2.0 * 3.0).unwrap();
    for (pr, pc) in [(10usize, 10usize), (290, 390), (150, 396)] {
        let img = image(rows, cols, grid, spacing, 0.0, fov, |_, r, c| {
            if r == pr && c == pc {
                1.0
            } else {
                0.0
            }
        });
        let out = o.compute(&img).unwrap();
        let pad = (out.rows - rows) / 2;
        // Ideal position (m from the axis) and its field angle.
        let (x, y) = (
            (pc as f64 + 0.5 - cols as f64 / 2.0) * out.sample_spacing_m,
            (pr as f64 + 0.5 - rows as f64 / 2.0) * out.sample_spacing_m,
        );
        let h = x.hypot(y);
        let real_mm = t
            .chief_image_point_mm(&cam, ObjectField::Infinity { tan_theta: h / f })
            .unwrap()[0];
        let s = real_mm * 1e-3 / h;
        let (want_r, want_c) = (
            y * s / spacing + out.rows as f64 / 2.0 - 0.5,
            x * s / spacing + out.cols as f64 / 2.0 - 0.5,
        );
        let (mr, mc, _, _) = moments(
            &out.data,
            out.cols,
            want_r.round() as usize,
            want_c.round() as usize,
            4,
        );
        let shift_px = (h * (s - 1.0)).abs() / spacing;
        println!(
            "point ({pr}, {pc}): distortion moves it {shift_px:.2} px; image centroid off the chief ray by ({:.3}, {:.3}) px",
            mr - want_r,
            mc - want_c
        );
        assert!(shift_px > 1.2, "the test needs a visible distortion");
        assert!((mr - want_r).abs() < 0.1 && (mc - want_c).abs() < 0.1);
        let _ = pad;
    }
}

/// (iv) Relative illumination: a uniform scene through the traced lens falls off as
/// `LensCamera::relative_illumination` of the same lens (within 1 %).
#[test]
fn relative_illumination_matches_the_lens_camera() {
    let grid = WavelengthGrid::new(550.0, 550.0, 10.0).unwrap();
    let (rows, cols, spacing, f) = (241usize, 321usize, 10e-6, 4.38e-3);
    let fov = 2.0 * (cols as f64 * spacing / 2.0 / f).atan().to_degrees();
    let o = Optics::from_config(&lens_config(4.0)).unwrap();
    let img = image(rows, cols, grid, spacing, 0.0, fov, |_, _, _| 1.0);
    let out = o.compute(&img).unwrap();
    let t = TracedLens::from_file(&lens_path("dgauss.82deg.4.38mm.json"), 4.0, 4.38).unwrap();
    let cam = t.camera(f64::INFINITY, 2.0 * 3.0).unwrap();
    let centre = |r: f64, c: f64| out.data[(r as usize) * out.cols + c as usize];
    let (r0, c0) = (out.rows / 2, out.cols / 2);
    let e0 = centre(r0 as f64, c0 as f64) as f64;
    for frac in [0.3f64, 0.6, 0.85] {
        let (r, c) = (r0 as f64 + frac * 100.0, c0 as f64 + frac * 140.0);
        let (x, y) = (
            (c + 0.5 - out.cols as f64 / 2.0) * spacing,
            (r + 0.5 - out.rows as f64 / 2.0) * spacing,
        );
        let h_mm = x.hypot(y) * 1e3;
        let want = cam.relative_illumination(&[h_mm], 64, 550.0)[0];
        let got = centre(r, c) as f64 / e0;
        println!("film height {h_mm:.3} mm: RI {got:.4} (lens camera {want:.4})");
        assert!(
            (got / want - 1.0).abs() < 0.01,
            "{h_mm} mm: {got} vs {want}"
        );
    }
}

/// (v) Bad input: errors that name the key or file, never a panic or NaN.
#[test]
fn bad_configs_give_clear_errors() {
    let base = "f_number = 4.0\nfocal_length_mm = 4.38\nshading = \"none\"\n";
    let err = |text: &str| -> String {
        match OpticsConfig::from_toml_str(text, "test.toml").and_then(|c| Optics::from_config(&c)) {
            Ok(_) => panic!("accepted: {text}"),
            Err(e) => e.to_string(),
        }
    };
    let e = err(&format!(
        "{base}blur = {{ method = \"shift-variant\", field_heights = 1 }}"
    ));
    assert!(e.contains("blur.field_heights"), "{e}");
    let e = err(&format!(
        "{base}blur = {{ method = \"shift-variant\", fields = 3 }}"
    ));
    assert!(e.contains("fields"), "{e}");
    let e = err(&format!("{base}blur = {{ method = \"sideways\" }}"));
    assert!(e.contains("sideways"), "{e}");
    let e = err(&format!(
        "{base}blur = {{ method = \"shift-variant\", lens_file = \"/nonexistent/lens.json\" }}"
    ));
    assert!(e.contains("/nonexistent/lens.json"), "{e}");
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, "{ \"surfaces\": [ { \"radius\": 1.0 } ] }").unwrap();
    let e = err(&format!(
        "{base}blur = {{ method = \"shift-variant\", lens_file = \"{}\" }}",
        bad.display()
    ));
    assert!(e.contains("bad.json"), "{e}");
    let lens = lens_path("dgauss.82deg.4.38mm.json");
    let e = err(&format!(
        "f_number = 4.0\nfocal_length_mm = 4.38\nblur = {{ method = \"shift-variant\", lens_file = \"{}\" }}",
        lens.display()
    ));
    assert!(e.contains("shading"), "{e}");
    let e = err(&format!(
        "f_number = 4.0\nfocal_length_mm = 6.0\nshading = \"none\"\nblur = {{ method = \"shift-variant\", lens_file = \"{}\" }}",
        lens.display()
    ));
    assert!(e.contains("focal_length_mm"), "{e}");
    let e = err(&format!(
        "f_number = 0.5\nfocal_length_mm = 4.38\nshading = \"none\"\nblur = {{ method = \"shift-variant\", lens_file = \"{}\" }}",
        lens.display()
    ));
    assert!(e.contains("f_number"), "{e}");
    let e = err(&format!(
        "{base}[blur]\nmethod = \"shift-variant\"\n[blur.field_zernike]\nfield_height_normalized = [0.0, 1.0]\nzernike_um = [[0.0]]\n"
    ));
    assert!(e.contains("blur.field_zernike.zernike_um"), "{e}");
    let e = err(&format!("{base}[blur]\nmethod = \"shift-variant\"\n[blur.field_zernike]\nfield_height_normalized = [0.0, 1.0]\nzernike_um = [[0.0], [0.0, nan]]\n"));
    assert!(e.contains("zernike_um[1][1]"), "{e}");
    let e = err(&format!(
        "{base}blur = {{ method = \"shift-invariant\", lens_file = \"x.json\" }}"
    ));
    assert!(e.contains("blur.method"), "{e}");
}

/// The example `examples/lens-dgauss-shift-variant.toml`: its `[optics.config]` parses and builds
/// (lens file resolved against the example's folder, as the pipeline does).
#[test]
fn example_config_builds() {
    let path = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/lens-dgauss-shift-variant.toml"
    ));
    let text = std::fs::read_to_string(&path).unwrap();
    let doc: toml::Table = toml::from_str(&text).unwrap();
    let optics = doc["optics"].as_table().unwrap()["config"].clone();
    let mut c: OpticsConfig = optics.try_into().unwrap();
    let b = c.blur.as_mut().unwrap();
    let lens = b.lens_file.as_mut().unwrap();
    *lens = path.parent().unwrap().join(&*lens);
    let o = Optics::from_config(&c).unwrap();
    assert!(o.shift_variant().is_some());
}
